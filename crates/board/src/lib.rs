//! The driver board's fixed facts, which the plant, the controller, the FMUs' variable
//! tables and the HIL bridge all need: one place for each (docs/model.md §2.1, §2.6).

/// The DACs' full scale (V): a code of [`DAC_MAX_CODE`] is this many volts, and the plant
/// holds its DAC inputs within `0..=DAC_FULL_SCALE`.
pub const DAC_FULL_SCALE: f64 = 10.0;

/// The DACs' largest code: 16-bit converters.
pub const DAC_MAX_CODE: u16 = u16::MAX;

/// The encoder's resolution (m per count): the 1.2 nm of the flight device, the default
/// of both the plant's and the controller's `q_enc`.
pub const ENCODER_RESOLUTION: f64 = 1.2e-9;
