//! Two plain clients a model of the inchworm needs besides the actuators: [`Logger`], a
//! sink that keeps every UID it reads as a column of `f64`, and [`Sampler`], the rate
//! transition between a fast source and a slower actor.

use std::marker::PhantomData;

use interface::{Data, Read, UniqueIdentifier, Update, Write};

use crate::fmu_client::FmuValue;

/// Every value each input UID brought, in arrival order, as `f64` (exact for `i32` and
/// `bool`); a column by UID, named by the UID's type (`EncoderCounts<0>`).
#[derive(Debug, Default)]
pub struct Logger {
    columns: Vec<(String, Vec<f64>)>,
}

impl Logger {
    /// The column of UID `U`, if it was read, its complete rows ([`Logger::rows`]).
    pub fn column<U: UniqueIdentifier>(&self) -> Option<&[f64]> {
        self.named(&interface::trim_type_name::<U>())
    }

    /// A column by its name, its complete rows.
    pub fn named(&self, name: &str) -> Option<&[f64]> {
        let rows = self.rows();
        self.columns.iter().find(|(n, _)| n == name).map(|(_, c)| &c[..rows])
    }

    /// The rows every column has. The logger's actor reads its inputs one by one; when a
    /// model ends, the inputs still running may have brought one value more than the
    /// others (an actor that steps once more before it sees its inputs close).
    pub fn rows(&self) -> usize {
        self.columns.iter().map(|(_, c)| c.len()).min().unwrap_or(0)
    }

    /// The column names, in the order of their first value.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.columns.iter().map(|(n, _)| n.as_str())
    }
}

impl Update for Logger {}

impl<U> Read<U> for Logger
where
    U: UniqueIdentifier,
    U::DataType: FmuValue,
{
    fn read(&mut self, data: Data<U>) {
        let name = interface::trim_type_name::<U>();
        let x = (*data).to_f64();
        match self.columns.iter_mut().find(|(n, _)| *n == name) {
            Some((_, c)) => c.push(x),
            None => self.columns.push((name, vec![x])),
        }
    }
}

/// Passes the latest value of `U` on: in an actor `Actor<Sampler<U>, 1, 2>` it takes every
/// sample of a 1 kHz output and hands each second one (t = 0, 2 ms, 4 ms...) to a 500 Hz
/// input.
pub struct Sampler<U: UniqueIdentifier> {
    value: Option<Data<U>>,
    uid: PhantomData<U>,
}

impl<U: UniqueIdentifier> Default for Sampler<U> {
    fn default() -> Self {
        Sampler { value: None, uid: PhantomData }
    }
}

impl<U: UniqueIdentifier> Update for Sampler<U> {}

impl<U: UniqueIdentifier> Read<U> for Sampler<U> {
    fn read(&mut self, data: Data<U>) {
        self.value = Some(data);
    }
}

impl<U: UniqueIdentifier> Write<U> for Sampler<U> {
    fn write(&mut self) -> Option<Data<U>> {
        self.value.clone()
    }
}
