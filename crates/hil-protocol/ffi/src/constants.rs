//! The IW_* constants of the header: sizes, frame types, streams, roles, fault reasons,
//! status bits, return codes and watchdog states, each checked against the protocol
//! crate's value at compile time.

use inchworm_hil_protocol as iw;
use inchworm_hil_protocol::FaultReason;

/// Protocol version in every frame header.
pub const IW_VERSION: u8 = 1;
/// Largest encoded frame in bytes; a buffer of this size always suffices for iw_encode.
pub const IW_MAX_FRAME: usize = 26;
/// Largest COBS-encoded frame (without the 0x00 delimiter).
pub const IW_MAX_COBS_FRAME: usize = 27;
/// Default watchdog limit in silent periods.
pub const IW_DEFAULT_WATCHDOG_PERIODS: u32 = 3;
/// Lock-step board: wall-clock periods without any valid frame before the link counts
/// as dead (iw_watchdog_init_lockstep).
pub const IW_LOCKSTEP_DEAD_LINK_PERIODS: u32 = 250;

/// Frame type HELLO (stream 0, 8-byte payload).
pub const IW_TYPE_HELLO: u8 = 0x01;
/// Frame type ARM (stream 0, no payload).
pub const IW_TYPE_ARM: u8 = 0x02;
/// Frame type DISARM (stream 0, no payload).
pub const IW_TYPE_DISARM: u8 = 0x03;
/// Frame type FAULT (stream 0, 8-byte payload).
pub const IW_TYPE_FAULT: u8 = 0x04;
/// Frame type DAC (stream 1, 10-byte payload).
pub const IW_TYPE_DAC: u8 = 0x10;
/// Frame type ENCODER (stream 2, 12-byte payload).
pub const IW_TYPE_ENCODER: u8 = 0x11;

/// Stream of HELLO, ARM, DISARM, FAULT.
pub const IW_STREAM_CONTROL: u16 = 0;
/// Stream of DAC frames (controller to board).
pub const IW_STREAM_DAC: u16 = 1;
/// Stream of ENCODER frames (board to controller).
pub const IW_STREAM_ENCODER: u16 = 2;

/// HELLO role: controller.
pub const IW_ROLE_CONTROLLER: u8 = 1;
/// HELLO role: board.
pub const IW_ROLE_BOARD: u8 = 2;

/// FAULT reason: watchdog, no valid frame for N periods (detail = missed periods).
pub const IW_FAULT_SILENCE: u8 = 1;
/// FAULT reason: frames lost (detail = gap size).
pub const IW_FAULT_SEQUENCE_GAP: u8 = 2;
/// FAULT reason: nothing valid from the peer for too long (detail = periods or repeats).
pub const IW_FAULT_LINK_DEAD: u8 = 3;
/// FAULT reason: too many bad frames (detail = count).
pub const IW_FAULT_CORRUPT: u8 = 4;
/// FAULT reason: hard real-time deadline missed.
pub const IW_FAULT_OVERRUN: u8 = 5;
/// FAULT reason: stopped by a person.
pub const IW_FAULT_OPERATOR: u8 = 6;
/// FAULT reason: HELLO versions or parameters disagree.
pub const IW_FAULT_PROTOCOL_MISMATCH: u8 = 7;
/// FAULT reason: the board refused the sender, which holds no session with it (detail:
/// 1 another controller holds an armed session, 2 address not allowed, 3 HELLO first).
pub const IW_FAULT_SESSION_REFUSED: u8 = 8;

/// ENCODER status bit: the board is armed.
pub const IW_STATUS_ARMED: u16 = 1;
/// ENCODER status bit: the safe state is latched.
pub const IW_STATUS_SAFE: u16 = 2;
/// ENCODER status bit: the board missed a deadline since its previous ENCODER frame.
pub const IW_STATUS_OVERRUN: u16 = 4;
/// ENCODER status bit: lock-step mode.
pub const IW_STATUS_LOCKSTEP: u16 = 8;

/// Success.
pub const IW_OK: i32 = 0;
/// A required pointer was NULL, or a watchdog was not initialised by iw_watchdog_init.
pub const IW_ERR_NULL: i32 = -1;
/// Fewer bytes than the smallest frame (14).
pub const IW_ERR_TOO_SHORT: i32 = -2;
/// The frame does not start with "IW".
pub const IW_ERR_BAD_MAGIC: i32 = -3;
/// The header's protocol version is not IW_VERSION.
pub const IW_ERR_VERSION: i32 = -4;
/// The length field announces more bytes than were given.
pub const IW_ERR_TRUNCATED: i32 = -5;
/// More bytes than the length field announces.
pub const IW_ERR_TRAILING_BYTES: i32 = -6;
/// CRC-32 mismatch: the frame was damaged in transit.
pub const IW_ERR_CRC: i32 = -7;
/// Intact frame of an unknown type.
pub const IW_ERR_UNKNOWN_TYPE: i32 = -8;
/// Intact frame on the wrong stream for its type.
pub const IW_ERR_WRONG_STREAM: i32 = -9;
/// Intact frame whose length field is not its type's fixed length.
pub const IW_ERR_BAD_LENGTH: i32 = -10;
/// Intact frame with an undefined payload value (role, reason, flag or status bits).
pub const IW_ERR_BAD_PAYLOAD: i32 = -11;
/// The output buffer is too small.
pub const IW_ERR_BUFFER_TOO_SMALL: i32 = -12;
/// Malformed COBS data (empty, contains 0x00, cut short or non-canonical).
pub const IW_ERR_COBS: i32 = -13;
/// An invalid argument value (e.g. an unknown fault reason).
pub const IW_ERR_INVALID_ARGUMENT: i32 = -14;
/// Internal error: a Rust panic was caught (a bug; please report).
pub const IW_ERR_PANIC: i32 = -99;

/// Watchdog state returned by iw_watchdog_state: outputs safe codes, not counting.
pub const IW_STATE_DISARMED: i32 = 0;
/// Watchdog state: applying requested codes, counting silent periods.
pub const IW_STATE_ARMED: i32 = 1;
/// Watchdog state: safe state latched until iw_watchdog_arm.
pub const IW_STATE_SAFE: i32 = 2;

const _: () = {
    assert!(IW_VERSION == iw::VERSION);
    assert!(IW_MAX_FRAME == iw::MAX_FRAME);
    assert!(IW_MAX_COBS_FRAME == iw::cobs::max_encoded_len(iw::MAX_FRAME));
    assert!(IW_DEFAULT_WATCHDOG_PERIODS == iw::DEFAULT_WATCHDOG_PERIODS);
    assert!(IW_TYPE_HELLO == iw::frame_type::HELLO);
    assert!(IW_TYPE_ARM == iw::frame_type::ARM);
    assert!(IW_TYPE_DISARM == iw::frame_type::DISARM);
    assert!(IW_TYPE_FAULT == iw::frame_type::FAULT);
    assert!(IW_TYPE_DAC == iw::frame_type::DAC);
    assert!(IW_TYPE_ENCODER == iw::frame_type::ENCODER);
    assert!(IW_STREAM_CONTROL == iw::stream::CONTROL);
    assert!(IW_STREAM_DAC == iw::stream::DAC);
    assert!(IW_STREAM_ENCODER == iw::stream::ENCODER);
    assert!(IW_STATUS_ARMED == iw::status::ARMED);
    assert!(IW_STATUS_SAFE == iw::status::SAFE);
    assert!(IW_STATUS_OVERRUN == iw::status::OVERRUN);
    assert!(IW_STATUS_LOCKSTEP == iw::status::LOCKSTEP);
    assert!(IW_FAULT_PROTOCOL_MISMATCH == FaultReason::ProtocolMismatch as u8);
    assert!(IW_FAULT_SILENCE == FaultReason::Silence as u8);
    assert!(IW_FAULT_SESSION_REFUSED == FaultReason::SessionRefused as u8);
};
