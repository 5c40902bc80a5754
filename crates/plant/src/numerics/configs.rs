//! Propagator tables per configuration (mode × slipping set), built on first use and
//! shared between clones of a plant, and the cached products of the sub-scan tail.

use std::sync::Arc;

use super::propagators::Propagators;
use super::ticks::{ticks_of, LEVELS};
use crate::linear;
use crate::{Mode, Plant, PlantParams, N_PLAYS};

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
    phi: &[nalgebra::SMatrix<f64, D, D>; LEVELS],
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

/// The propagator of a whole step of `h` seconds that stops nowhere, for the event loop's
/// steps without a stop and the quiet step alike: what the event loop's products over such
/// a step make of its first state (each scan segment's [`Propagators::advance`], the
/// tail's [`product`], the sub-tick Taylor step), multiplied out into one matrix in their
/// order. It differs from the chain of products by rounding only (a product of at most
/// seven factors, each rounding ≤ 14 u of the sum of the magnitudes). `None` for a step of
/// 2³² ticks (3.9 ms) or more, which has more than two scan segments: the chain takes it.
pub(crate) fn whole_step<const D: usize>(
    t: &Propagators<D>,
    h: f64,
) -> Option<nalgebra::SMatrix<f64, D, D>> {
    let (mut left, rest) = ticks_of(h);
    if left >= 1 << 32 {
        return None;
    }
    let mut m = nalgebra::SMatrix::<f64, D, D>::identity();
    let fine = 1u64 << t.scan_level;
    // The segments as `advance_held` cuts a step without a stop, each in `advance`'s order.
    while left >= fine {
        let points = ((left >> t.scan_level) as usize).min(t.scan_points);
        let mut ticks = (points as u64) << t.scan_level;
        left -= ticks;
        while ticks != 0 {
            m = t.phi[ticks.trailing_zeros() as usize] * m;
            ticks &= ticks - 1;
        }
    }
    if left > 0 {
        m = product(&t.phi, left) * m;
    }
    if rest > 0.0 {
        let am = t.a * m;
        m += am * rest + (t.a * am) * (0.5 * rest * rest);
    }
    m.iter().all(|x| x.is_finite()).then_some(m)
}

/// A whole step's propagator ([`whole_step`]) and the step length it is for (bits of `h`).
#[derive(Clone, Debug)]
pub(crate) struct Whole<const D: usize> {
    pub(crate) h: u64,
    pub(crate) phi: Option<nalgebra::SMatrix<f64, D, D>>,
}

impl<const D: usize> Whole<D> {
    pub(crate) fn new(t: &Propagators<D>, h: f64) -> Self {
        Whole { h: h.to_bits(), phi: whole_step(t, h) }
    }
}

/// The tables of configuration `key`, which [`Plant::config`] has built. Takes the field,
/// not the plant, so the plant's other fields stay free to change while it is borrowed.
#[inline(always)]
pub(crate) fn table(configs: &[Option<ConfigTable>], key: usize) -> &Propagators<{ linear::N }> {
    configs[key].as_deref().expect("configuration tables are built by Plant::config")
}

/// Every configuration in the order of its key ([`Plant::config_key`]): its mode, its
/// sliding set (bit `i` set: play `i` slides) and its system matrix.
pub(crate) fn every_configuration(
    p: &PlantParams,
) -> impl Iterator<Item = (Mode, u32, linear::Matrix)> + '_ {
    [Mode::Hold, Mode::Locked, Mode::Drive, Mode::Free].into_iter().flat_map(move |mode| {
        (0..1u32 << N_PLAYS).map(move |sliding| {
            let w_s: f64 =
                (0..N_PLAYS).filter(|&i| sliding & (1 << i) == 0).map(|i| p.play_weight[i]).sum();
            (mode, sliding, linear::system_matrix(p, mode, w_s))
        })
    })
}

impl Plant {
    #[inline]
    pub(crate) fn config_key(&self) -> usize {
        (self.state.mode.index() << N_PLAYS) | usize::from(self.state.hysteresis.sliding)
    }

    /// Builds the tables of the current configuration if it has none yet; returns its key
    /// for [`table`].
    #[inline]
    pub(crate) fn config(&mut self) -> usize {
        let key = self.config_key();
        if self.solver.configs[key].is_none() {
            self.build_config(key);
        }
        key
    }

    #[cold]
    #[inline(never)]
    fn build_config(&mut self, key: usize) {
        let w_s = self.state.hysteresis.sticking_weight();
        let a = linear::system_matrix(&self.params, self.state.mode, w_s);
        let watched = vec![
            linear::xi_row(&self.params, w_s),
            linear::drive_rate_row(&self.params, self.state.mode),
        ];
        let t = Arc::new(Propagators::new(a, watched, self.solver.chain.scan_level));
        self.solver.configs[key] = Some(t);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The configurations come in the order of their keys, so a table indexed by
    /// [`Plant::config_key`] may be built from them in turn.
    #[test]
    fn every_configuration_comes_at_its_key() {
        let p = PlantParams::fia20();
        let keys: Vec<usize> = every_configuration(&p)
            .map(|(mode, sliding, _)| (mode.index() << N_PLAYS) | sliding as usize)
            .collect();
        assert_eq!(keys, (0..4 << N_PLAYS).collect::<Vec<_>>());
    }
}
