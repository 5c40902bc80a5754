//! What the SSD and `.ssv` readers share: attributes, line numbers, and the check that a
//! file is complete.

use quick_xml::events::{BytesStart, Event};

use crate::Error;

pub(super) fn attr(e: &BytesStart, name: &str) -> Result<Option<String>, Error> {
    for a in e.attributes() {
        let a = a.map_err(|err| Error::Ssp(format!("malformed attribute: {err}")))?;
        if a.key.local_name().into_inner() == name {
            return a
                .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                .map(|v| Some(v.into_owned()))
                .map_err(|err| Error::Ssp(format!("attribute {name}: {err}")));
        }
    }
    Ok(None)
}

pub(super) fn required(e: &BytesStart, name: &str) -> Result<String, Error> {
    attr(e, name)?.ok_or_else(|| {
        Error::Ssp(format!("<{}> lacks the attribute {name}", e.local_name().into_inner()))
    })
}

/// 1-based line of byte offset `pos` in `xml`.
pub(super) fn line_of(xml: &str, pos: u64) -> usize {
    let end = (pos as usize).min(xml.len());
    xml.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The elements open so far. quick-xml reports the end of the text as a plain end of
/// file even inside an element, so a file cut short would parse as a complete, smaller
/// one: the file is complete only when every element it opened is closed.
#[derive(Default)]
pub(super) struct Open {
    names: Vec<String>,
    root_seen: bool,
}

impl Open {
    pub(super) fn track(&mut self, ev: &Event) {
        match ev {
            Event::Start(e) => {
                self.root_seen = true;
                self.names.push(e.name().as_ref().to_owned());
            }
            Event::Empty(_) => self.root_seen = true,
            Event::End(_) => {
                self.names.pop();
            }
            _ => {}
        }
    }

    pub(super) fn complete(&self, file: &str, xml: &str) -> Result<(), Error> {
        match self.names.last() {
            Some(inner) => Err(Error::Ssp(format!(
                "{file}line {}: the file ends inside <{}>: expected </{inner}> (a truncated file?)",
                line_of(xml, xml.len() as u64),
                self.names.join("> <"),
            ))),
            None if !self.root_seen => {
                Err(Error::Ssp(format!("{file}has no root element (an empty file?)")))
            }
            None => Ok(()),
        }
    }
}
