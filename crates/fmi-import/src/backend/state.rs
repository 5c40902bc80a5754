//! FMU state for both standards: each backend resolves its own six functions (with its own
//! names, signatures and status values) into a [`States`]; taking, restoring, freeing,
//! serializing and reading back a state, the capability checks and the refusals are here.

use std::os::raw::{c_int, c_void};

use inchworm_fmi_abi::fmi2::{
    fmi2Byte, fmi2DeSerializeFMUstateTYPE, fmi2FreeFMUstateTYPE, fmi2GetFMUstateTYPE,
    fmi2SerializeFMUstateTYPE, fmi2SerializedFMUstateSizeTYPE, fmi2SetFMUstateTYPE,
};
use inchworm_fmi_abi::fmi3::{
    fmi3Byte, fmi3DeserializeFMUStateTYPE, fmi3FreeFMUStateTYPE, fmi3GetFMUStateTYPE,
    fmi3SerializeFMUStateTYPE, fmi3SerializedFMUStateSizeTYPE, fmi3SetFMUStateTYPE,
};

use super::{Calls, RawState};
use crate::binary::Binary;
use crate::{FmuError, ImportError, Status};

/// The largest serialized FMU state accepted, bytes: the size is the FMU's own figure, and
/// a broken one must not make the master allocate without bound.
pub(crate) const MAX_STATE_BYTES: usize = 1 << 30;

/// The names of one standard's state functions and capability flags.
pub(crate) struct Names {
    pub get: &'static str,
    pub set: &'static str,
    pub free: &'static str,
    pub size: &'static str,
    pub serialize: &'static str,
    pub deserialize: &'static str,
    /// `canGetAndSetFMUstate` / `canGetAndSetFMUState`.
    pub get_set_flag: &'static str,
    /// `canSerializeFMUstate` / `canSerializeFMUState`.
    pub serialize_flag: &'static str,
}

// The C shapes both standards share: (instance, state…) → status; `B` is the standard's
// byte type (`fmi2Byte` is a `char`, `fmi3Byte` a `uint8_t`).
type Get = unsafe extern "C" fn(*mut c_void, *mut RawState) -> c_int;
type Set = unsafe extern "C" fn(*mut c_void, RawState) -> c_int;
type Size = unsafe extern "C" fn(*mut c_void, RawState, *mut usize) -> c_int;
type Serialize<B> = unsafe extern "C" fn(*mut c_void, RawState, *mut B, usize) -> c_int;
type Deserialize<B> = unsafe extern "C" fn(*mut c_void, *const B, usize, *mut RawState) -> c_int;

// The shapes are exactly both standards' own signatures: this compiles only if they are.
#[allow(clippy::type_complexity)]
const _SAME_SHAPES: [fn(
    (fmi2GetFMUstateTYPE, fmi2SetFMUstateTYPE, fmi2FreeFMUstateTYPE),
    (fmi3GetFMUStateTYPE, fmi3SetFMUStateTYPE, fmi3FreeFMUStateTYPE),
) -> [(Get, Set, Get); 2]; 1] = [|a, b| [a, b]];
#[allow(clippy::type_complexity)]
const _SAME_SERIAL_SHAPES: [fn(
    (fmi2SerializedFMUstateSizeTYPE, fmi2SerializeFMUstateTYPE, fmi2DeSerializeFMUstateTYPE),
    (fmi3SerializedFMUStateSizeTYPE, fmi3SerializeFMUStateTYPE, fmi3DeserializeFMUStateTYPE),
) -> (
    (Size, Serialize<fmi2Byte>, Deserialize<fmi2Byte>),
    (Size, Serialize<fmi3Byte>, Deserialize<fmi3Byte>),
); 1] = [|a, b| (a, b)];

/// One instance's state functions: `None` where the FMU does not declare the capability.
pub(crate) struct States<B: 'static> {
    names: &'static Names,
    status: fn(c_int) -> Status,
    instance: *mut c_void,
    get_set: Option<(Get, Set, Get)>,
    serial: Option<(Size, Serialize<B>, Deserialize<B>)>,
}

/// What [`crate::CsFmu`] calls, whatever the byte type.
pub(crate) trait StateCalls {
    fn get(&self, cx: &mut Calls) -> Result<RawState, FmuError>;
    fn set(&self, cx: &mut Calls, state: RawState) -> Result<(), FmuError>;
    fn free(&self, cx: &mut Calls, state: RawState) -> Result<(), FmuError>;
    fn serialize(&self, cx: &mut Calls, state: RawState) -> Result<Vec<u8>, FmuError>;
    fn deserialize(&self, cx: &mut Calls, bytes: &[u8]) -> Result<RawState, FmuError>;
    /// The standard's names of the state calls (for the refusals made before a call).
    fn names(&self) -> &'static Names;
}

impl<B: Copy + 'static> States<B> {
    /// Resolves the functions of the capabilities the FMU declares (`get_set`,
    /// `serialize`); one declared but missing refuses the binary.
    ///
    /// # Safety
    /// The standard's signatures of these functions must have the shapes above with `B`
    /// its byte type (they do in FMI 2.0 and FMI 3.0).
    pub unsafe fn resolve(
        binary: &Binary,
        names: &'static Names,
        status: fn(c_int) -> Status,
        (get_set, serialize): (bool, bool),
    ) -> Result<Self, ImportError> {
        let (g, s) = (names.get_set_flag, names.serialize_flag);
        let get_set = match (
            binary.capability::<Get>(names.get, g, get_set)?,
            binary.capability::<Set>(names.set, g, get_set)?,
            binary.capability::<Get>(names.free, g, get_set)?,
        ) {
            (Some(a), Some(b), Some(c)) => Some((a, b, c)),
            _ => None,
        };
        let serial = match (
            binary.capability::<Size>(names.size, s, serialize)?,
            binary.capability::<Serialize<B>>(names.serialize, s, serialize)?,
            binary.capability::<Deserialize<B>>(names.deserialize, s, serialize)?,
        ) {
            (Some(a), Some(b), Some(c)) => Some((a, b, c)),
            _ => None,
        };
        Ok(States { names, status, instance: std::ptr::null_mut(), get_set, serial })
    }

    /// The instance the calls go to, once it exists.
    pub fn bind(&mut self, instance: *mut c_void) {
        self.instance = instance;
    }

    fn get_set(&self, cx: &Calls, function: &'static str) -> Result<(Get, Set, Get), FmuError> {
        self.get_set.ok_or_else(|| cx.unsupported(function, self.names.get_set_flag))
    }

    #[allow(clippy::type_complexity)]
    fn serial(
        &self,
        cx: &Calls,
        function: &'static str,
    ) -> Result<(Size, Serialize<B>, Deserialize<B>), FmuError> {
        self.serial.ok_or_else(|| cx.unsupported(function, self.names.serialize_flag))
    }

    /// A state the FMU handed out, refused if NULL.
    fn non_null(
        &self,
        cx: &Calls,
        function: &'static str,
        state: RawState,
    ) -> Result<RawState, FmuError> {
        if state.is_null() {
            let ok = Status::Ok.spelled(function);
            return Err(cx.invalid(function, format!("the FMU returned {ok} but no state (NULL)")));
        }
        Ok(state)
    }
}

// SAFETY of every call below: the standard's own functions, resolved from its library for
// the shapes above, on the live instance `bind` gave (CsFmu calls nothing after the
// instance is freed), with buffers of the lengths passed.
impl<B: Copy + 'static> StateCalls for States<B> {
    fn get(&self, cx: &mut Calls) -> Result<RawState, FmuError> {
        let f = self.names.get;
        let (get, _, _) = self.get_set(cx, f)?;
        // NULL asks the FMU for a new state (non-NULL would overwrite that one).
        let (i, mut state) = (self.instance, std::ptr::null_mut());
        cx.call(f, || (self.status)(unsafe { get(i, &mut state) }))?;
        self.non_null(cx, f, state)
    }

    fn set(&self, cx: &mut Calls, state: RawState) -> Result<(), FmuError> {
        let f = self.names.set;
        let (_, set, _) = self.get_set(cx, f)?;
        let i = self.instance;
        cx.call(f, || (self.status)(unsafe { set(i, state) }))
    }

    fn free(&self, cx: &mut Calls, state: RawState) -> Result<(), FmuError> {
        let f = self.names.free;
        let (_, _, free) = self.get_set(cx, f)?;
        let (i, mut state) = (self.instance, state);
        cx.call(f, || (self.status)(unsafe { free(i, &mut state) }))
    }

    fn serialize(&self, cx: &mut Calls, state: RawState) -> Result<Vec<u8>, FmuError> {
        let f = self.names.serialize;
        let (size_of, serialize, _) = self.serial(cx, f)?;
        let (i, mut size) = (self.instance, 0usize);
        cx.call(self.names.size, || (self.status)(unsafe { size_of(i, state, &mut size) }))?;
        if size > MAX_STATE_BYTES {
            return Err(cx.invalid(
                self.names.size,
                format!(
                    "the FMU gave a serialized state of {size} bytes (limit {MAX_STATE_BYTES})"
                ),
            ));
        }
        let mut bytes = vec![0u8; size];
        cx.call(f, || {
            (self.status)(unsafe { serialize(i, state, bytes.as_mut_ptr().cast(), size) })
        })?;
        Ok(bytes)
    }

    fn deserialize(&self, cx: &mut Calls, bytes: &[u8]) -> Result<RawState, FmuError> {
        let f = self.names.deserialize;
        let (_, _, deserialize) = self.serial(cx, f)?;
        let (i, mut state) = (self.instance, std::ptr::null_mut());
        cx.call(f, || {
            (self.status)(unsafe { deserialize(i, bytes.as_ptr().cast(), bytes.len(), &mut state) })
        })?;
        self.non_null(cx, f, state)
    }

    fn names(&self) -> &'static Names {
        self.names
    }
}
