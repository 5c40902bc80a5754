//! The `InchwormController` FMU's state as bytes: the inputs, the last sample written, the
//! sample clock and the controller's own state.

use inchworm_controller::{Controller, Sample};
use inchworm_fmi_export::{Reader, Writer};

use super::{Clock, ControllerFmu};

impl ControllerFmu {
    pub(super) fn save(&self, w: &mut Writer) {
        w.f64(f64::from(self.encoder_counts));
        w.f64(self.reference);
        w.u8(u8::from(self.last.is_some()));
        if let Some(s) = &self.last {
            let (e, d, f, b) =
                (s.servo_error, s.disturbance_estimate, s.step_forward, s.step_backward);
            for v in s.dac.iter().chain(&[e, d, f, b, s.fraction]).chain(&s.scale_weights) {
                w.f64(*v);
            }
            // The board's widths: 16-bit DAC codes, a 32-bit step count.
            s.codes.iter().for_each(|c| w.0.extend_from_slice(&c.to_le_bytes()));
            w.0.extend_from_slice(&s.n_steps.to_le_bytes());
            [s.moving, s.iterated, s.no_root].into_iter().for_each(|b| w.u8(u8::from(b)));
        }
        match &self.controller {
            None => w.u8(0),
            Some(c) => {
                // Format 2: the marker 2 and the clock, then the controller's own bytes.
                w.u8(2);
                let Clock { origin, ticks, latch } = self.clock;
                w.f64(origin.unwrap_or(f64::NAN));
                w.u64(ticks);
                w.u8(u8::from(latch.is_some()));
                let (counts, reference) = latch.unwrap_or((0, 0.0));
                w.0.extend_from_slice(&counts.to_le_bytes());
                w.f64(reference);
                c.save_state(w.0);
            }
        }
    }

    pub(super) fn load(&mut self, bytes: &[u8]) -> Result<(), String> {
        // The last sample and the clock have fixed sizes, so the controller's own bytes
        // start at a known offset: inputs, marker, sample, controller marker, clock.
        let marker_at = if bytes.get(16) == Some(&1) { 17 + SAMPLE_BYTES } else { 17 };
        let head = marker_at + 1 + if bytes.get(marker_at) == Some(&2) { CLOCK_BYTES } else { 0 };
        let (head, own) = bytes.split_at_checked(head).ok_or("controller FMU state truncated")?;
        let mut r = Reader::new(head, "controller FMU state");
        self.encoder_counts = r.f64()? as i32;
        self.reference = r.f64()?;
        if r.bool()? {
            let mut f = [0.0; 18];
            for v in f.iter_mut() {
                *v = r.f64()?;
            }
            let mut code = || Ok::<_, String>(u16::from_le_bytes(le(&mut r)?));
            let codes = [code()?, code()?, code()?];
            let n_steps = u32::from_le_bytes(le(&mut r)?);
            self.last = Some(Sample {
                dac: [f[0], f[1], f[2]],
                codes,
                servo_error: f[3],
                disturbance_estimate: f[4],
                step_forward: f[5],
                step_backward: f[6],
                fraction: f[7],
                scale_weights: std::array::from_fn(|i| f[8 + i]),
                n_steps,
                moving: r.bool()?,
                iterated: r.bool()?,
                no_root: r.bool()?,
            });
        }
        let controller = r.u8()?;
        if controller > 2 {
            return Err(format!("controller FMU state: unknown controller marker {controller}"));
        }
        // Format 1 (marker 1) held no clock: it was always taken at a sample instant
        // (steps were whole samples), so the next step's t is s_0 and nothing is latched.
        self.clock = Clock::default();
        if controller == 2 {
            let origin = r.f64()?;
            let ticks = r.u64()?;
            let latched = r.bool()?;
            let counts = i32::from_le_bytes(le(&mut r)?);
            let reference = r.f64()?;
            if !origin.is_finite() || !reference.is_finite() {
                return Err("controller FMU state: a non-finite sample clock".into());
            }
            self.clock = Clock {
                origin: Some(origin),
                ticks,
                latch: latched.then_some((counts, reference)),
            };
        }
        if controller != 0 {
            let mut c = Controller::new(self.params.clone())
                .map_err(|e| format!("state holds invalid parameters: {e}"))?;
            c.load_state(own)?;
            self.controller = Some(c);
        } else if !own.is_empty() {
            return Err(
                "controller FMU state: trailing bytes after an uninitialized controller".into()
            );
        }
        r.finish()
    }
}

/// A saved [`Sample`]: 18 f64, three u16 codes, a u32 step count and three flags.
pub(super) const SAMPLE_BYTES: usize = 18 * 8 + 3 * 2 + 4 + 3;

/// The saved [`Clock`] of format 2: origin f64, ticks u64, latch flag, latched counts i32
/// and reference f64 (zeros when nothing is latched).
pub(super) const CLOCK_BYTES: usize = 8 + 8 + 1 + 4 + 8;

/// `N` little-endian bytes: the state-bytes Reader reads no u16 or u32.
fn le<const N: usize>(r: &mut Reader) -> Result<[u8; N], String> {
    let mut b = [0; N];
    for x in b.iter_mut() {
        *x = r.u8()?;
    }
    Ok(b)
}
