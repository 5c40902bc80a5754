//! FMI 3.0 Co-Simulation import behind the same [`CsFmu`]: a master loads an FMI 3.0 FMU
//! exactly as an FMI 2.0 one, and an SSP may mix both.
//!
//! * `modelDescription.xml` with `fmiVersion="3.*"` is read here into the same
//!   [`ModelDescription`]: `<Float64>` is a Real, `<Int32>` an Integer, `<Boolean>` and
//!   `<String>` as in FMI 2.0, `instantiationToken` the guid. Variables of the other FMI 3.0
//!   types (Float32, the other integer widths, Enumeration, Binary, Clock), arrays (with
//!   `<Dimension>`) and the independent variable are left out: [`CsFmu`]'s scalar calls
//!   cannot address them, so a master asking for one gets "unknown variable".
//! * The binary is `binaries/<arch>-<os>/` (FMI 3.0 platform tuple); its `fmi3*` functions
//!   are resolved and wrapped in an adapter with the FMI 2.0 signatures [`CsFmu`] calls.
//!   The adapter is the component: each wrapper finds the FMI 3.0 instance and functions
//!   through it. `fmi2SetupExperiment` + `fmi2EnterInitializationMode` become
//!   `fmi3EnterInitializationMode`; `fmi2DoStep` becomes `fmi3DoStep`, whose
//!   `terminateSimulation` turns an OK step into an error (the FMU asked to stop) and whose
//!   `earlyReturn`/`eventHandlingNeeded` cannot occur (instantiated without event mode and
//!   without early return). Errors name the FMI 2.0 call [`CsFmu`] made; the FMU's own log
//!   message names the `fmi3*` function.
//! * The logger is a plain function in FMI 3.0, so it is Rust here and feeds the same `log`
//!   records as the FMI 2.0 C logger.

#![allow(non_snake_case)]

use std::ffi::{CStr, CString};
use std::mem::ManuallyDrop;
use std::os::raw::{c_char, c_void};
use std::path::Path;

use inchworm_fmi_abi::fmi3::*;
use libloading::Library;
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::binary::{Api, Binary};
use crate::description::{line_column, Causality, CoSimulation, DefaultExperiment, Initial};
use crate::description::{ModelDescription, VarType, Variability, Variable};
use crate::ffi::*;
use crate::logger::LogEnv;
use crate::{archive::Unpacked, CsFmu, FmuError, ImportError};

/// Whether the root element declares `fmiVersion="3.*"` (anything else, malformed XML
/// included, is left to the FMI 2.0 parser and its error messages).
pub(crate) fn declares_fmi3(xml: &str) -> bool {
    let mut reader = Reader::from_str(xml);
    loop {
        match reader.read_event() {
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => {
                return e.name().as_ref() == "fmiModelDescription"
                    && attrs_of(&e)
                        .ok()
                        .and_then(|a| get(&a, "fmiVersion").map(|v| v.trim().starts_with("3.")))
                        .unwrap_or(false);
            }
            Ok(Event::Eof) | Err(_) => return false,
            Ok(_) => {}
        }
    }
}

type Attrs = Vec<(String, String)>;

fn attrs_of(e: &BytesStart<'_>) -> Result<Attrs, String> {
    let mut out = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| format!("malformed attribute: {err}"))?;
        let key = a.key.as_ref().to_owned();
        let value = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| format!("attribute {key}: {err}"))?
            .into_owned();
        out.push((key, value));
    }
    Ok(out)
}

fn get<'a>(a: &'a Attrs, key: &str) -> Option<&'a str> {
    a.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

fn flag(a: &Attrs, key: &str) -> Result<bool, String> {
    match get(a, key).map(str::trim) {
        None | Some("false") | Some("0") => Ok(false),
        Some("true") | Some("1") => Ok(true),
        Some(v) => Err(format!("{key}=\"{v}\" is not a boolean (true/false)")),
    }
}

fn number<T: std::str::FromStr>(a: &Attrs, key: &str, what: &str) -> Result<Option<T>, String> {
    match get(a, key) {
        None => Ok(None),
        Some(v) => v.trim().parse().map(Some).map_err(|_| format!("{key}=\"{v}\" is not {what}")),
    }
}

/// A variable element being read: kept unless it turns out to be an array.
struct Pending {
    var: Option<Variable>,
    array: bool,
}

/// Reads an FMI 3.0 `modelDescription.xml` into the FMI 2.0 shape (see the module docs).
pub(crate) fn parse_description(xml: &str) -> Result<ModelDescription, ImportError> {
    let mut reader = Reader::from_str(xml);
    reader.config_mut().check_end_names = true;
    let err = |pos: usize, message: String| {
        let (line, column) = line_column(xml, pos);
        ImportError::Description { line, column, message }
    };
    let mut md = ModelDescription::default();
    let mut stack: Vec<String> = Vec::new();
    let mut pending: Option<Pending> = None;
    loop {
        let pos = reader.buffer_position() as usize;
        let (e, empty) = match reader.read_event() {
            Ok(Event::Start(e)) => (e, false),
            Ok(Event::Empty(e)) => (e, true),
            Ok(Event::End(_)) => {
                stack.pop();
                if stack.len() == 2 && stack[1] == "ModelVariables" {
                    finish(&mut md, pending.take()).map_err(|m| err(pos, m))?;
                }
                continue;
            }
            Ok(Event::Eof) => break,
            Ok(_) => continue,
            Err(e) => {
                return Err(err(reader.error_position() as usize, format!("malformed XML: {e}")))
            }
        };
        let name = e.name().as_ref().to_owned();
        let a = attrs_of(&e).map_err(|m| err(pos, format!("<{name}>: {m}")))?;
        let at = |m: String| err(pos, format!("<{name}> {m}"));
        match (stack.len(), name.as_str()) {
            (0, "fmiModelDescription") => {
                let req =
                    |k: &str| get(&a, k).map(str::to_owned).ok_or_else(|| at(format!("lacks {k}")));
                md.fmi_version = req("fmiVersion")?.trim().to_owned();
                md.model_name = req("modelName")?;
                md.guid = req("instantiationToken")?;
                md.description = get(&a, "description").map(str::to_owned);
                md.generation_tool = get(&a, "generationTool").map(str::to_owned);
            }
            (0, other) => {
                return Err(at(format!(
                    "is the root element ({other}), expected <fmiModelDescription>"
                )))
            }
            (1, "CoSimulation") => {
                let id = get(&a, "modelIdentifier").unwrap_or("").trim().to_owned();
                if id.is_empty() {
                    return Err(at("lacks a modelIdentifier".into()));
                }
                md.co_simulation = Some(CoSimulation {
                    model_identifier: id,
                    needs_execution_tool: flag(&a, "needsExecutionTool").map_err(at)?,
                    can_handle_variable_communication_step_size: flag(
                        &a,
                        "canHandleVariableCommunicationStepSize",
                    )
                    .map_err(at)?,
                    can_be_instantiated_only_once_per_process: flag(
                        &a,
                        "canBeInstantiatedOnlyOncePerProcess",
                    )
                    .map_err(at)?,
                    can_get_and_set_fmu_state: flag(&a, "canGetAndSetFMUState").map_err(at)?,
                    can_serialize_fmu_state: flag(&a, "canSerializeFMUState").map_err(at)?,
                });
            }
            (1, "ModelExchange") => md.has_model_exchange = true,
            (1, "DefaultExperiment") => {
                let n = |k| number::<f64>(&a, k, "a number").map_err(at);
                md.default_experiment = Some(DefaultExperiment {
                    start_time: n("startTime")?,
                    stop_time: n("stopTime")?,
                    tolerance: n("tolerance")?,
                    step_size: n("stepSize")?,
                });
            }
            (2, ty) if stack[1] == "ModelVariables" => {
                let var = variable(ty, &a).map_err(at)?;
                let p = Pending { var, array: false };
                if empty {
                    finish(&mut md, Some(p)).map_err(|m| err(pos, m))?;
                } else {
                    pending = Some(p);
                }
            }
            (3, "Dimension") if stack[1] == "ModelVariables" => {
                if let Some(p) = pending.as_mut() {
                    p.array = true;
                }
            }
            _ => {}
        }
        if !empty {
            stack.push(name);
        }
    }
    if md.model_name.is_empty() && md.fmi_version.is_empty() {
        return Err(err(0, "no <fmiModelDescription> element".into()));
    }
    Ok(md)
}

fn finish(md: &mut ModelDescription, p: Option<Pending>) -> Result<(), String> {
    match p {
        Some(Pending { var: Some(v), array: false }) => {
            let name = v.name.clone();
            if md.add_variable(v) {
                Ok(())
            } else {
                Err(format!("a second variable named `{name}`"))
            }
        }
        _ => Ok(()),
    }
}

/// One variable element as an FMI 2.0-shaped scalar, or `None` for what [`CsFmu`] cannot
/// address (other types, the independent variable).
fn variable(element: &str, a: &Attrs) -> Result<Option<Variable>, String> {
    let ty = match element {
        "Float64" => VarType::Real,
        "Int32" => VarType::Integer,
        "Boolean" => VarType::Boolean,
        "String" => VarType::String,
        _ => return Ok(None),
    };
    let name = get(a, "name").ok_or("lacks the required attribute name")?.to_owned();
    let vr = number::<u32>(a, "valueReference", "an unsigned 32-bit integer")?
        .ok_or_else(|| format!("name=\"{name}\" lacks the required attribute valueReference"))?;
    let causality = match get(a, "causality").map(str::trim) {
        None => Causality::Local,
        Some("structuralParameter") => Causality::Parameter,
        Some(c) => Causality::parse(c).ok_or_else(|| format!("causality=\"{c}\" is unknown"))?,
    };
    if causality == Causality::Independent {
        return Ok(None);
    }
    let variability = match get(a, "variability").map(str::trim) {
        None if ty == VarType::Real => Variability::Continuous,
        None => Variability::Discrete,
        Some(v) => {
            Variability::parse(v).ok_or_else(|| format!("variability=\"{v}\" is unknown"))?
        }
    };
    let initial = match get(a, "initial").map(str::trim) {
        None => None,
        Some(i) => Some(Initial::parse(i).ok_or_else(|| format!("initial=\"{i}\" is unknown"))?),
    };
    Ok(Some(Variable {
        name,
        vr,
        ty,
        causality,
        variability,
        initial,
        start: get(a, "start").map(str::to_owned),
        description: get(a, "description").map(str::to_owned),
        declared_type: get(a, "declaredType").map(str::to_owned),
    }))
}

/// The `fmi3*` functions the adapter calls.
#[derive(Clone, Copy)]
struct Api3 {
    set_debug_logging: fmi3SetDebugLoggingTYPE,
    instantiate: fmi3InstantiateCoSimulationTYPE,
    free_instance: fmi3FreeInstanceTYPE,
    enter_initialization_mode: fmi3EnterInitializationModeTYPE,
    exit_initialization_mode: fmi3ExitInitializationModeTYPE,
    terminate: fmi3TerminateTYPE,
    reset: fmi3ResetTYPE,
    get_float64: fmi3GetFloat64TYPE,
    get_int32: fmi3GetInt32TYPE,
    get_boolean: fmi3GetBooleanTYPE,
    get_string: fmi3GetStringTYPE,
    set_float64: fmi3SetFloat64TYPE,
    set_int32: fmi3SetInt32TYPE,
    set_boolean: fmi3SetBooleanTYPE,
    set_string: fmi3SetStringTYPE,
    do_step: fmi3DoStepTYPE,
}

/// The component [`CsFmu`] holds for an FMI 3.0 FMU.
struct Adapter {
    instance: fmi3Instance,
    api: Api3,
    experiment: (Option<f64>, f64, Option<f64>),
    /// The target of the adapter's own log records, as of the FMU's.
    name: String,
}

unsafe fn adapter<'a>(c: fmi2Component) -> &'a mut Adapter {
    // SAFETY (caller): `c` is the Box<Adapter> pointer `load` gave the CsFmu.
    &mut *(c as *mut Adapter)
}

extern "C" fn types_platform() -> *const c_char {
    c"default".as_ptr()
}

extern "C" fn get_version() -> *const c_char {
    c"3.0".as_ptr()
}

unsafe extern "C" fn set_debug_logging(
    c: fmi2Component,
    on: fmi2Boolean,
    n: usize,
    cats: *const fmi2String,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.set_debug_logging)(a.instance, on != 0, n, cats)
}

unsafe extern "C" fn instantiate(
    _: fmi2String,
    _: fmi2Type,
    _: fmi2String,
    _: fmi2String,
    _: *const fmi2CallbackFunctions,
    _: fmi2Boolean,
    _: fmi2Boolean,
) -> fmi2Component {
    // `load` instantiates through fmi3InstantiateCoSimulation; this is never called.
    std::ptr::null_mut()
}

unsafe extern "C" fn free_instance(c: fmi2Component) {
    let a = Box::from_raw(c as *mut Adapter);
    (a.api.free_instance)(a.instance);
}

unsafe extern "C" fn setup_experiment(
    c: fmi2Component,
    tolerance_defined: fmi2Boolean,
    tolerance: fmi2Real,
    start: fmi2Real,
    stop_defined: fmi2Boolean,
    stop: fmi2Real,
) -> fmi2Status {
    let a = adapter(c);
    a.experiment =
        ((tolerance_defined != 0).then_some(tolerance), start, (stop_defined != 0).then_some(stop));
    fmi2OK
}

unsafe extern "C" fn enter_initialization_mode(c: fmi2Component) -> fmi2Status {
    let a = adapter(c);
    let (tol, start, stop) = a.experiment;
    (a.api.enter_initialization_mode)(
        a.instance,
        tol.is_some(),
        tol.unwrap_or(0.0),
        start,
        stop.is_some(),
        stop.unwrap_or(0.0),
    )
}

unsafe extern "C" fn exit_initialization_mode(c: fmi2Component) -> fmi2Status {
    let a = adapter(c);
    (a.api.exit_initialization_mode)(a.instance)
}

unsafe extern "C" fn terminate(c: fmi2Component) -> fmi2Status {
    let a = adapter(c);
    (a.api.terminate)(a.instance)
}

unsafe extern "C" fn reset(c: fmi2Component) -> fmi2Status {
    let a = adapter(c);
    (a.api.reset)(a.instance)
}

unsafe extern "C" fn get_real(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *mut fmi2Real,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.get_float64)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn get_integer(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *mut fmi2Integer,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.get_int32)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn get_boolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *mut fmi2Boolean,
) -> fmi2Status {
    let a = adapter(c);
    // Read as bytes: an FMU writing another byte than 0 or 1 must not make an invalid bool.
    let mut raw = vec![0u8; n];
    let s = (a.api.get_boolean)(a.instance, vr, n, raw.as_mut_ptr() as *mut fmi3Boolean, n);
    if n > 0 && !v.is_null() {
        for (out, b) in std::slice::from_raw_parts_mut(v, n).iter_mut().zip(raw) {
            *out = fmi2Boolean::from(b != 0);
        }
    }
    s
}

unsafe extern "C" fn get_string(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *mut fmi2String,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.get_string)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn set_real(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *const fmi2Real,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.set_float64)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn set_integer(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *const fmi2Integer,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.set_int32)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn set_boolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *const fmi2Boolean,
) -> fmi2Status {
    let a = adapter(c);
    let values: Vec<bool> = if n == 0 || v.is_null() {
        Vec::new()
    } else {
        std::slice::from_raw_parts(v, n).iter().map(|&b| b != 0).collect()
    };
    (a.api.set_boolean)(a.instance, vr, n, values.as_ptr(), n)
}

unsafe extern "C" fn set_string(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    n: usize,
    v: *const fmi2String,
) -> fmi2Status {
    let a = adapter(c);
    (a.api.set_string)(a.instance, vr, n, v, n)
}

unsafe extern "C" fn do_step(
    c: fmi2Component,
    t: fmi2Real,
    h: fmi2Real,
    no_prior: fmi2Boolean,
) -> fmi2Status {
    let a = adapter(c);
    let (mut event, mut terminate, mut early, mut last) = (false, false, false, t);
    let s = (a.api.do_step)(
        a.instance,
        t,
        h,
        no_prior != 0,
        &mut event,
        &mut terminate,
        &mut early,
        &mut last,
    );
    if s <= fmi2Warning && (terminate || early || event) {
        let why = if terminate {
            "the FMU asked to terminate the simulation"
        } else if early {
            "the FMU returned early"
        } else {
            "the FMU needs event handling, which this master does not do"
        };
        crate::logger::emit(
            log::Level::Error,
            &a.name,
            format_args!("fmi3DoStep from t = {t} s: {why} (last successful time {last} s)"),
        );
        return fmi2Error;
    }
    s
}

unsafe extern "C" fn no_status(c: fmi2Component) -> fmi2Status {
    let _ = c;
    fmi2Error
}

unsafe extern "C" fn no_status_kind<T>(
    _: fmi2Component,
    _: fmi2StatusKind,
    _: *mut T,
) -> fmi2Status {
    fmi2Error
}

/// The FMI 3.0 logger: a plain function, fed into the same `log` records.
unsafe extern "C" fn log_message(
    env: fmi3InstanceEnvironment,
    status: fmi3Status,
    category: fmi3String,
    message: fmi3String,
) {
    crate::logger::inchworm_fmi_import_log(env, std::ptr::null(), status, category, message);
}

fn load_library(dir: &Path, relative: &Path) -> Result<(Library, Api3, String), ImportError> {
    let path = dir.join(relative);
    let shown = relative.to_path_buf();
    crate::binary::check_elf(&path)
        .map_err(|message| ImportError::Load { library: shown.clone(), message })?;
    // SAFETY: loading runs the library's initializers; an FMU's binary is trusted code.
    let library = unsafe { Library::new(&path) }
        .map_err(|e| ImportError::Load { library: shown.clone(), message: e.to_string() })?;
    macro_rules! required {
        ($name:literal) => {{
            // SAFETY: the type is the FMI 3.0 signature of this function.
            match unsafe { library.get(concat!($name, "\0").as_bytes()) } {
                Ok(sym) => *sym,
                Err(_) => {
                    return Err(ImportError::MissingSymbol {
                        library: shown.clone(),
                        symbol: $name,
                    })
                }
            }
        }};
    }
    let get_version: fmi3GetVersionTYPE = required!("fmi3GetVersion");
    let api = Api3 {
        set_debug_logging: required!("fmi3SetDebugLogging"),
        instantiate: required!("fmi3InstantiateCoSimulation"),
        free_instance: required!("fmi3FreeInstance"),
        enter_initialization_mode: required!("fmi3EnterInitializationMode"),
        exit_initialization_mode: required!("fmi3ExitInitializationMode"),
        terminate: required!("fmi3Terminate"),
        reset: required!("fmi3Reset"),
        get_float64: required!("fmi3GetFloat64"),
        get_int32: required!("fmi3GetInt32"),
        get_boolean: required!("fmi3GetBoolean"),
        get_string: required!("fmi3GetString"),
        set_float64: required!("fmi3SetFloat64"),
        set_int32: required!("fmi3SetInt32"),
        set_boolean: required!("fmi3SetBoolean"),
        set_string: required!("fmi3SetString"),
        do_step: required!("fmi3DoStep"),
    };
    // SAFETY: returns a static NUL-terminated string.
    let p = unsafe { get_version() };
    let version = if p.is_null() {
        "(NULL)".to_owned()
    } else {
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    };
    if !version.starts_with("3.") {
        return Err(ImportError::BinaryVersion(version));
    }
    Ok((library, api, version))
}

/// [`CsFmu::load`] for an FMU whose `modelDescription.xml` declares FMI 3.0.
pub(crate) fn load(
    path: &Path,
    unpacked: Unpacked,
    instance_name: &str,
    logging_on: bool,
) -> Result<CsFmu, FmuError> {
    let import = |source: ImportError| FmuError::Import { path: path.to_path_buf(), source };
    let description = parse_description(&unpacked.model_description).map_err(import)?;
    let model = description.model_name.clone();
    let Some(cs) = &description.co_simulation else {
        return Err(FmuError::NotCoSimulation { model });
    };
    let relative = crate::binary::library_path_for(
        crate::binary::fmi3_platform(),
        unpacked.dir(),
        &cs.model_identifier,
    )
    .map_err(import)?;
    let (library, api3, version) = load_library(unpacked.dir(), &relative).map_err(import)?;

    let nul = |what| import(ImportError::Nul { what });
    let c_name = CString::new(instance_name).map_err(|_| nul("the instance name"))?;
    let c_token =
        CString::new(description.guid.as_str()).map_err(|_| nul("the instantiation token"))?;
    // FMI 3.0 resourcePath: a native path ending in a separator.
    let resources =
        format!("{}{}", unpacked.dir().join("resources").display(), std::path::MAIN_SEPARATOR);
    let c_resources = CString::new(resources).map_err(|_| nul("the resource path"))?;
    let env = Box::new(LogEnv { instance: instance_name.to_owned() });
    // SAFETY: the FMI 3.0 signature; every pointer passed lives until after
    // fmi3FreeInstance (owned by the returned CsFmu, dropped after the free).
    let instance = unsafe {
        (api3.instantiate)(
            c_name.as_ptr(),
            c_token.as_ptr(),
            c_resources.as_ptr(),
            false,
            logging_on,
            false,
            false,
            std::ptr::null(),
            0,
            &*env as *const LogEnv as *mut c_void,
            Some(log_message),
            None,
        )
    };
    if instance.is_null() {
        drop(env);
        drop(library);
        return Err(import(ImportError::Instantiate { instance: instance_name.to_owned() }));
    }
    let component = Box::into_raw(Box::new(Adapter {
        instance,
        api: api3,
        experiment: (None, 0.0, None),
        name: instance_name.to_owned(),
    })) as fmi2Component;
    let api = Api {
        get_types_platform: types_platform,
        get_version,
        set_debug_logging,
        instantiate,
        free_instance,
        setup_experiment,
        enter_initialization_mode,
        exit_initialization_mode,
        terminate,
        reset,
        get_real,
        get_integer,
        get_boolean,
        get_string,
        set_real,
        set_integer,
        set_boolean,
        set_string,
        do_step,
        cancel_step: no_status,
        get_status: no_status_kind::<fmi2Status>,
        get_real_status: no_status_kind::<fmi2Real>,
        get_integer_status: no_status_kind::<fmi2Integer>,
        get_boolean_status: no_status_kind::<fmi2Boolean>,
        get_string_status: no_status_kind::<fmi2String>,
        get_fmu_state: None,
        set_fmu_state: None,
        free_fmu_state: None,
        serialized_fmu_state_size: None,
        serialize_fmu_state: None,
        de_serialize_fmu_state: None,
    };
    // The FMI 2.0 callbacks are unused by an FMI 3.0 FMU; kept for CsFmu's shape.
    let callbacks = Box::new(fmi2CallbackFunctions {
        logger: None,
        allocateMemory: None,
        freeMemory: None,
        stepFinished: None,
        componentEnvironment: std::ptr::null_mut(),
    });
    let binary = Binary { api, path: relative, types_platform: "default".into(), version, library };
    Ok(CsFmu {
        component,
        api,
        model,
        instance_name: instance_name.to_owned(),
        description,
        start_time: 0.0,
        steps_done: 0,
        step_size: 0.0,
        fatal: None,
        callbacks: ManuallyDrop::new(callbacks),
        env: ManuallyDrop::new(env),
        c_strings: ManuallyDrop::new([c_name, c_token, c_resources]),
        binary: ManuallyDrop::new(binary),
        unpacked,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const XML: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="3.0" modelName="M" instantiationToken="{t}">
  <CoSimulation modelIdentifier="m" canGetAndSetFMUState="true"/>
  <DefaultExperiment stepSize="0.01"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="x" valueReference="1" causality="output" initial="calculated"/>
    <Int32 name="n" valueReference="2" causality="parameter" variability="fixed" start="3"/>
    <Boolean name="b" valueReference="3" causality="input" start="false"/>
    <Float64 name="a" valueReference="4" causality="parameter" variability="tunable" start="1 2">
      <Dimension start="2"/>
    </Float64>
    <UInt8 name="u" valueReference="5" causality="input" start="0"/>
    <Float64 name="y" valueReference="6" causality="input" start="0"><Annotations/></Float64>
  </ModelVariables>
  <ModelStructure><Output valueReference="1"/></ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn fmi3_description_reads_scalars_and_leaves_out_what_csfmu_cannot_address() {
        assert!(declares_fmi3(XML));
        assert!(!declares_fmi3(&XML.replace("3.0", "2.0")));
        assert!(!declares_fmi3("not xml <"));
        let md = parse_description(XML).unwrap();
        assert_eq!((md.fmi_version.as_str(), md.guid.as_str()), ("3.0", "{t}"));
        let cs = md.co_simulation.as_ref().unwrap();
        assert!(cs.can_get_and_set_fmu_state);
        assert_eq!(md.default_experiment.unwrap().step_size, Some(0.01));
        let vars: Vec<_> =
            md.variables.iter().map(|v| (v.name.as_str(), v.ty, v.variability)).collect();
        assert_eq!(
            vars,
            [
                ("x", VarType::Real, Variability::Continuous),
                ("n", VarType::Integer, Variability::Fixed),
                ("b", VarType::Boolean, Variability::Discrete),
                ("y", VarType::Real, Variability::Continuous),
            ]
        );
        assert_eq!(md.variable("n").unwrap().start.as_deref(), Some("3"));
        let dup = XML.replace(r#"name="y""#, r#"name="x""#);
        let e = parse_description(&dup).unwrap_err().to_string();
        assert!(e.contains("a second variable named `x`"), "{e}");
        let bad = XML.replace(r#"valueReference="2""#, r#"valueReference="-2""#);
        assert!(parse_description(&bad).unwrap_err().to_string().contains("valueReference"));
    }
}
