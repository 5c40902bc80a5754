//! Little-endian byte encoding of a model's state (plant, controller), for FMU state
//! serialization: the readers name what they read in every error.

pub struct Writer<'a>(pub &'a mut Vec<u8>);

impl Writer<'_> {
    pub fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    pub fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
}

pub struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    what: &'static str,
}

impl<'a> Reader<'a> {
    /// `what` names the state in error messages, e.g. "plant state".
    pub fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Reader { bytes, pos: 0, what }
    }
    fn take<const K: usize>(&mut self) -> Result<[u8; K], String> {
        let end = self.pos + K;
        let s = self
            .bytes
            .get(self.pos..end)
            .ok_or_else(|| format!("{} truncated at byte {}", self.what, self.pos))?;
        self.pos = end;
        Ok(s.try_into().expect("slice has length K"))
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take()?))
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    pub fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take::<1>()?[0])
    }
    pub fn bool(&mut self) -> Result<bool, String> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(format!("{}: invalid flag {b}", self.what)),
        }
    }
    pub fn finish(&self) -> Result<(), String> {
        if self.pos == self.bytes.len() {
            Ok(())
        } else {
            Err(format!("{}: {} trailing bytes", self.what, self.bytes.len() - self.pos))
        }
    }
}
