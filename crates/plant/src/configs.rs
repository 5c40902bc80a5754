//! Propagator tables per configuration (mode × slipping set), built on first use and
//! shared between clones of a plant, and the cached products of the sub-scan tail.

use std::sync::Arc;

use crate::linear::{self, Propagators};
use crate::{Plant, N_PLAYS};

/// Propagators of one configuration, shared between clones of a plant.
pub(crate) type ConfigTable = Arc<Propagators<{ linear::N }>>;

#[derive(Clone, Debug)]
pub(crate) struct Remainder {
    pub(crate) ticks: u64,
    pub(crate) phi: linear::Matrix,
}

#[derive(Clone, Debug)]
pub(crate) struct ChainRemainder {
    pub(crate) ticks: u64,
    pub(crate) phi: linear::ChainMatrix,
}

/// `e^{A ticks}` as the product of the dyadic table entries.
pub(crate) fn product<const D: usize>(
    phi: &[nalgebra::SMatrix<f64, D, D>; linear::LEVELS],
    ticks: u64,
) -> nalgebra::SMatrix<f64, D, D> {
    let mut m = nalgebra::SMatrix::<f64, D, D>::identity();
    for (l, p) in phi.iter().enumerate() {
        if ticks & (1 << l) != 0 {
            m = p * m;
        }
    }
    m
}

/// The tables of configuration `key`, which [`Plant::config`] has built. Takes the field,
/// not the plant, so the plant's other fields stay free to change while it is borrowed.
#[inline(always)]
pub(crate) fn table(configs: &[Option<ConfigTable>], key: usize) -> &Propagators<{ linear::N }> {
    configs[key].as_deref().expect("configuration tables are built by Plant::config")
}

impl Plant {
    #[inline]
    pub(crate) fn config_key(&self) -> usize {
        (self.mode.index() << N_PLAYS) | usize::from(self.hysteresis.sliding)
    }

    /// Builds the tables of the current configuration if it has none yet; returns its key
    /// for [`table`].
    #[inline]
    pub(crate) fn config(&mut self) -> usize {
        let key = self.config_key();
        if self.configs[key].is_none() {
            self.build_config(key);
        }
        key
    }

    #[cold]
    #[inline(never)]
    fn build_config(&mut self, key: usize) {
        let w_s = self.hysteresis.sticking_weight();
        let a = linear::system_matrix(&self.params, self.mode, w_s);
        let watched = vec![
            linear::xi_row(&self.params, w_s),
            linear::drive_rate_row(&self.params, self.mode),
        ];
        let t = Arc::new(Propagators::new(a, watched, self.chain.scan_level, |m| m.exp()));
        self.configs[key] = Some(t);
    }
}
