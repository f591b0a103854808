//! The FMI 2.0 Co-Simulation functions of pumpcyl's FMUs (docs/fmu.md): a thin C shell over
//! [`pumpcyl::fmu::Instance`]. Every function catches panics (a panic becomes `fmi2Error` with
//! a message through the logger, never an unwind across the C boundary), and every instance
//! owns its state, which `fmi2FreeInstance` releases.
//!
//! The host gets a handle, not an address: a number looked up in a registry of the live
//! instances, never reused. A call with a freed handle is `fmi2Error` with a message to the
//! logger the instance was made with, a call with a handle never given out is `fmi2Error`, and
//! a call on an instance another thread is using at that moment is `fmi2Error`: never a crash,
//! never a wait (docs/fmu.md#robustness). Which calls an instance accepts follows its phase
//! ([`pumpcyl::fmu::Phase`]).
//!
//! The functions follow the FMI 2.0.4 standard, section 2.1 (common) and 4.2
//! (Co-Simulation); functions the FMU does not support (FMU state, directional derivatives,
//! input derivatives, asynchronous steps) return `fmi2Error` with a logged reason, as the
//! capability flags of modelDescription.xml declare.

#![allow(clippy::missing_safety_doc)]

use pumpcyl::fmu::{Config, Instance, CONFIG_FILE};
use std::collections::{HashMap, VecDeque};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError, TryLockError};

type Status = c_int;
const OK: Status = 0;
const DISCARD: Status = 2;
const ERROR: Status = 3;

type Logger =
    unsafe extern "C" fn(*mut c_void, *const c_char, Status, *const c_char, *const c_char, ...);

/// fmi2CallbackFunctions.
#[repr(C)]
pub struct Callbacks {
    logger: Option<Logger>,
    allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    step_finished: Option<unsafe extern "C" fn(*mut c_void, Status)>,
    environment: *mut c_void,
}

/// Who an instance reports to: its name and the host's logger.
#[derive(Clone)]
struct Reporter {
    name: CString,
    logger: Option<Logger>,
    environment: *mut c_void,
}

// SAFETY: the environment pointer is the host's, only handed back to the host's logger; FMI
// 2.0 lets a host call an instance from any thread, one call at a time
unsafe impl Send for Reporter {}

impl Reporter {
    fn log(&self, status: Status, message: &str) {
        log(self.logger, self.environment, &self.name, status, message);
    }
}

/// One instance: the model and whom it reports to.
struct Component {
    reporter: Reporter,
    fmu: Instance,
    /// A panic left the instance unusable.
    failed: bool,
}

/// A registry entry: a live instance and whom it reports to, or whom a freed one reported to.
enum Entry {
    Live(Arc<Mutex<Component>>, Reporter),
    Freed(Reporter),
}

/// The instances by handle, the handles of freed ones (oldest first) and the next handle.
struct Registry {
    entries: HashMap<usize, Entry>,
    freed: VecDeque<usize>,
    next: usize,
}

/// Freed handles remembered, to name them in the log; an older one is an unknown handle.
const FREED_REMEMBERED: usize = 4096;

static REGISTRY: Mutex<Option<Registry>> = Mutex::new(None);

/// Run `f` on the registry (made on first use).
fn registry<T>(f: impl FnOnce(&mut Registry) -> T) -> T {
    let mut guard = REGISTRY.lock().unwrap_or_else(PoisonError::into_inner);
    let reg = guard.get_or_insert_with(|| Registry {
        entries: HashMap::new(),
        freed: VecDeque::new(),
        next: 1,
    });
    f(reg)
}

/// Register a new instance; its handle.
fn register(comp: Component) -> *mut c_void {
    registry(|r| {
        let handle = r.next;
        r.next += 1;
        let reporter = comp.reporter.clone();
        r.entries
            .insert(handle, Entry::Live(Arc::new(Mutex::new(comp)), reporter));
        handle as *mut c_void
    })
}

/// What a handle names: a live instance, a freed one's reporter, or nothing.
fn lookup(c: *mut c_void) -> Option<Result<Arc<Mutex<Component>>, Reporter>> {
    registry(|r| match r.entries.get(&(c as usize))? {
        Entry::Live(comp, _) => Some(Ok(Arc::clone(comp))),
        Entry::Freed(rep) => Some(Err(rep.clone())),
    })
}

/// Free the instance `c`: its reporter is kept, to name the handle if it comes back.
fn unregister(c: *mut c_void) -> Option<Result<Arc<Mutex<Component>>, Reporter>> {
    let key = c as usize;
    registry(|r| match r.entries.remove(&key)? {
        Entry::Live(comp, rep) => {
            r.entries.insert(key, Entry::Freed(rep));
            r.freed.push_back(key);
            if r.freed.len() > FREED_REMEMBERED {
                if let Some(old) = r.freed.pop_front() {
                    r.entries.remove(&old);
                }
            }
            Some(Ok(comp))
        }
        Entry::Freed(rep) => {
            r.entries.insert(key, Entry::Freed(rep.clone()));
            Some(Err(rep))
        }
    })
}

/// Send `message` to the host's logger, if it gave one.
fn log(
    logger: Option<Logger>,
    environment: *mut c_void,
    name: &CStr,
    status: Status,
    message: &str,
) {
    if let Some(logger) = logger {
        let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let category = if status >= ERROR {
            c"logStatusError"
        } else {
            c"logAll"
        };
        // SAFETY: the logger is the host's, called with valid C strings and a "%s" format
        unsafe {
            logger(
                environment,
                name.as_ptr(),
                status,
                category.as_ptr(),
                c"%s".as_ptr(),
                text.as_ptr(),
            )
        };
    }
}

/// Run `f` on the instance `c`, panics and errors turned into a logged `fmi2Error`; a freed
/// or unknown handle, or an instance busy in another call, is `fmi2Error`.
unsafe fn with(
    c: *mut c_void,
    what: &str,
    f: impl FnOnce(&mut Component) -> Result<Status, String>,
) -> Status {
    let comp = match lookup(c) {
        None => return ERROR,
        Some(Err(freed)) => {
            freed.log(ERROR, &format!("{what}: the instance was freed"));
            return ERROR;
        }
        Some(Ok(comp)) => comp,
    };
    let mut guard = match comp.try_lock() {
        Ok(g) => g,
        Err(TryLockError::Poisoned(p)) => p.into_inner(),
        Err(TryLockError::WouldBlock) => return ERROR,
    };
    let comp = &mut *guard;
    if comp.failed {
        comp.reporter
            .log(ERROR, &format!("{what}: the instance failed earlier"));
        return ERROR;
    }
    match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            comp.reporter.log(ERROR, &format!("{what}: {message}"));
            ERROR
        }
        Err(panic) => {
            let why = panic
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| panic.downcast_ref::<&str>().copied())
                .unwrap_or("internal error");
            // the instance's state is unknown after a panic: it refuses every later call
            comp.failed = true;
            comp.reporter.log(
                ERROR,
                &format!("{what}: internal error ({why}); please report it"),
            );
            ERROR
        }
    }
}

/// The references and values of an array call, checked for null.
unsafe fn slices<'a, T>(
    vr: *const u32,
    nvr: usize,
    values: *const T,
) -> Result<(&'a [u32], &'a [T]), String> {
    if nvr == 0 {
        return Ok((&[], &[]));
    }
    if vr.is_null() || values.is_null() {
        return Err("null value reference or value array".into());
    }
    // SAFETY: the host guarantees nvr elements behind both pointers
    Ok(unsafe {
        (
            std::slice::from_raw_parts(vr, nvr),
            std::slice::from_raw_parts(values, nvr),
        )
    })
}

unsafe fn slices_mut<'a, T>(
    vr: *const u32,
    nvr: usize,
    values: *mut T,
) -> Result<(&'a [u32], &'a mut [T]), String> {
    if nvr == 0 {
        return Ok((&[], &mut []));
    }
    if vr.is_null() || values.is_null() {
        return Err("null value reference or value array".into());
    }
    // SAFETY: the host guarantees nvr elements behind both pointers
    Ok(unsafe {
        (
            std::slice::from_raw_parts(vr, nvr),
            std::slice::from_raw_parts_mut(values, nvr),
        )
    })
}

/// The folder a `file:` URI names (percent-decoded; `file:///p`, `file:/p`, `file://localhost/p`).
fn uri_path(uri: &str) -> Result<PathBuf, String> {
    let rest = uri
        .strip_prefix("file://localhost")
        .or_else(|| uri.strip_prefix("file://"))
        .or_else(|| uri.strip_prefix("file:"))
        .ok_or_else(|| format!("resource location `{uri}` is not a file: URI"))?;
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).map_err(|e| e.to_string())?;
            out.push(u8::from_str_radix(hex, 16).map_err(|_| format!("bad escape in `{uri}`"))?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Ok(PathBuf::from(
        String::from_utf8(out).map_err(|e| e.to_string())?,
    ))
}

/// Read the configuration from the resources and check the GUID.
fn load(resources: &str, guid: &str) -> Result<Instance, String> {
    let path = uri_path(resources)?.join(CONFIG_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let config = Config::from_toml(&text).map_err(|e| e.to_string())?;
    if config.guid != guid {
        return Err(format!(
            "GUID {guid} does not match the FMU's {} (modelDescription.xml and {CONFIG_FILE} differ)",
            config.guid
        ));
    }
    Instance::new(config).map_err(|e| e.to_string())
}

unsafe fn text(p: *const c_char) -> String {
    if p.is_null() {
        String::new()
    } else {
        // SAFETY: a non-null C string from the host
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    name: *const c_char,
    kind: c_int,
    guid: *const c_char,
    resources: *const c_char,
    callbacks: *const Callbacks,
    _visible: c_int,
    _logging_on: c_int,
) -> *mut c_void {
    let result = catch_unwind(|| {
        // SAFETY: strings and callbacks from the host, checked for null
        let (name, guid, resources) = unsafe { (text(name), text(guid), text(resources)) };
        let (logger, environment) = if callbacks.is_null() {
            (None, std::ptr::null_mut())
        } else {
            // SAFETY: a non-null callback structure from the host
            let cb = unsafe { &*callbacks };
            (cb.logger, cb.environment)
        };
        let name = CString::new(name.replace('\0', " ")).unwrap_or_default();
        let loaded = if kind == 1 {
            load(&resources, &guid)
        } else {
            Err("this FMU supports Co-Simulation only".into())
        };
        match loaded {
            Ok(fmu) => Some(register(Component {
                reporter: Reporter {
                    name,
                    logger,
                    environment,
                },
                fmu,
                failed: false,
            })),
            Err(e) => {
                log(
                    logger,
                    environment,
                    &name,
                    ERROR,
                    &format!("fmi2Instantiate: {e}"),
                );
                None
            }
        }
    });
    match result {
        Ok(Some(p)) => p,
        _ => std::ptr::null_mut(),
    }
}

#[no_mangle]
pub extern "C" fn fmi2FreeInstance(c: *mut c_void) {
    let _ = catch_unwind(|| {
        if let Some(Err(freed)) = unregister(c) {
            freed.log(ERROR, "fmi2FreeInstance: the instance was already freed");
        }
    });
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: *mut c_void,
    _on: c_int,
    _n: usize,
    _categories: *const *const c_char,
) -> Status {
    unsafe { with(c, "fmi2SetDebugLogging", |_| Ok(OK)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: *mut c_void,
    _tolerance_defined: c_int,
    _tolerance: f64,
    start_s: f64,
    _stop_defined: c_int,
    _stop_s: f64,
) -> Status {
    unsafe {
        with(c, "fmi2SetupExperiment", |comp| {
            comp.fmu
                .setup_experiment(start_s)
                .map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2EnterInitializationMode", |comp| {
            comp.fmu.enter_initialization().map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2ExitInitializationMode", |comp| {
            comp.fmu.exit_initialization().map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2Terminate", |comp| {
            comp.fmu.terminate().map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: *mut c_void) -> Status {
    unsafe {
        with(c, "fmi2Reset", |comp| {
            comp.fmu.reset().map_err(|e| e.to_string())?;
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut f64,
) -> Status {
    unsafe {
        with(c, "fmi2GetReal", |comp| {
            let (vr, values) = slices_mut(vr, n, values)?;
            for (r, v) in vr.iter().zip(values.iter_mut()) {
                *v = comp.fmu.get_real(*r).map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *const f64,
) -> Status {
    unsafe {
        with(c, "fmi2SetReal", |comp| {
            let (vr, values) = slices(vr, n, values)?;
            for (r, v) in vr.iter().zip(values) {
                comp.fmu.set_real(*r, *v).map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *mut c_int,
) -> Status {
    unsafe {
        with(c, "fmi2GetBoolean", |comp| {
            let (vr, values) = slices_mut(vr, n, values)?;
            for (r, v) in vr.iter().zip(values.iter_mut()) {
                *v = c_int::from(comp.fmu.get_boolean(*r).map_err(|e| e.to_string())?);
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: *mut c_void,
    vr: *const u32,
    n: usize,
    values: *const c_int,
) -> Status {
    unsafe {
        with(c, "fmi2SetBoolean", |comp| {
            let (vr, values) = slices(vr, n, values)?;
            for (r, v) in vr.iter().zip(values) {
                comp.fmu
                    .set_boolean(*r, *v != 0)
                    .map_err(|e| e.to_string())?;
            }
            Ok(OK)
        })
    }
}

/// Integer and String variables: the FMU has none.
unsafe fn none_of_type(c: *mut c_void, what: &str, n: usize) -> Status {
    unsafe {
        with(c, what, |_| {
            if n == 0 {
                Ok(OK)
            } else {
                Err("this FMU has no variables of that type".into())
            }
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *mut c_int,
) -> Status {
    unsafe { none_of_type(c, "fmi2GetInteger", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *const c_int,
) -> Status {
    unsafe { none_of_type(c, "fmi2SetInteger", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *mut *const c_char,
) -> Status {
    unsafe { none_of_type(c, "fmi2GetString", n) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: *mut c_void,
    _vr: *const u32,
    n: usize,
    _v: *const *const c_char,
) -> Status {
    unsafe { none_of_type(c, "fmi2SetString", n) }
}

/// A capability the FMU does not declare.
unsafe fn unsupported(c: *mut c_void, what: &str) -> Status {
    unsafe {
        with(c, what, |_| {
            Err("not supported by this FMU (see modelDescription.xml)".into())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: *mut c_void, _s: *mut *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2GetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: *mut c_void, _s: *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2SetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: *mut c_void, _s: *mut *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2FreeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: *mut c_void,
    _s: *mut c_void,
    _n: *mut usize,
) -> Status {
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: *mut c_void,
    _s: *mut c_void,
    _b: *mut c_char,
    _n: usize,
) -> Status {
    unsafe { unsupported(c, "fmi2SerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: *mut c_void,
    _b: *const c_char,
    _n: usize,
    _s: *mut *mut c_void,
) -> Status {
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: *mut c_void,
    _u: *const u32,
    _nu: usize,
    _z: *const u32,
    _nz: usize,
    _dv: *const f64,
    _dz: *mut f64,
) -> Status {
    unsafe { unsupported(c, "fmi2GetDirectionalDerivative") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: *mut c_void,
    _vr: *const u32,
    _n: usize,
    _o: *const c_int,
    _v: *const f64,
) -> Status {
    unsafe { unsupported(c, "fmi2SetRealInputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: *mut c_void,
    _vr: *const u32,
    _n: usize,
    _o: *const c_int,
    _v: *mut f64,
) -> Status {
    unsafe { unsupported(c, "fmi2GetRealOutputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: *mut c_void,
    t: f64,
    h: f64,
    _no_set_prior: c_int,
) -> Status {
    unsafe {
        with(c, "fmi2DoStep", |comp| {
            comp.fmu.do_step(t, h).map_err(|e| e.to_string())?;
            if let Some(note) = comp.fmu.take_note() {
                comp.reporter.log(OK, &format!("fmi2DoStep: {note}"));
            }
            Ok(OK)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: *mut c_void) -> Status {
    unsafe { unsupported(c, "fmi2CancelStep") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: *mut c_void, _k: c_int, _v: *mut Status) -> Status {
    unsafe { with(c, "fmi2GetStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: *mut c_void, _k: c_int, _v: *mut f64) -> Status {
    unsafe { with(c, "fmi2GetRealStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: *mut c_void, _k: c_int, _v: *mut c_int) -> Status {
    unsafe { with(c, "fmi2GetIntegerStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: *mut c_void, _k: c_int, _v: *mut c_int) -> Status {
    unsafe { with(c, "fmi2GetBooleanStatus", |_| Ok(DISCARD)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: *mut c_void,
    _k: c_int,
    _v: *mut *const c_char,
) -> Status {
    unsafe { with(c, "fmi2GetStringStatus", |_| Ok(DISCARD)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_uris_name_their_folder() {
        assert_eq!(
            uri_path("file:///tmp/a%20b/resources").unwrap(),
            PathBuf::from("/tmp/a b/resources")
        );
        assert_eq!(uri_path("file:/tmp/x").unwrap(), PathBuf::from("/tmp/x"));
        assert_eq!(
            uri_path("file://localhost/tmp/x/").unwrap(),
            PathBuf::from("/tmp/x/")
        );
        assert!(uri_path("http://example.org/x").is_err());
    }

    use pumpcyl::fmu::{Controller, ModelKind};
    use pumpcyl::rig::Rig;

    /// An instance of an FMU of `model` and `controller` on the article's rig, its
    /// configuration written to a folder of its own; null callbacks (no logger).
    fn instantiate(model: ModelKind, controller: Controller) -> *mut c_void {
        let config = Config::new(model, controller, false, Rig::default());
        let dir = std::env::temp_dir().join(format!(
            "pumpcyl-fmu-test-{}-{model:?}-{controller:?}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(CONFIG_FILE), config.to_toml()).unwrap();
        let uri = CString::new(format!("file://{}", dir.display())).unwrap();
        let guid = CString::new(config.guid.clone()).unwrap();
        // SAFETY: valid C strings; null callbacks are allowed
        let c = unsafe {
            fmi2Instantiate(
                c"test".as_ptr(),
                1,
                guid.as_ptr(),
                uri.as_ptr(),
                std::ptr::null(),
                0,
                0,
            )
        };
        let _ = std::fs::remove_dir_all(&dir);
        assert!(!c.is_null(), "{model:?}/{controller:?} did not instantiate");
        c
    }

    fn x(c: *mut c_void) -> (Status, f64) {
        let mut v = f64::NAN;
        // SAFETY: one value reference, one value
        let status = unsafe { fmi2GetReal(c, &100u32, 1, &mut v) };
        (status, v)
    }

    const KINDS: [(ModelKind, Controller); 4] = [
        (ModelKind::Emulator, Controller::Article),
        (ModelKind::Emulator, Controller::External),
        (ModelKind::Linear, Controller::Article),
        (ModelKind::Linear, Controller::External),
    ];

    #[test]
    fn freed_unknown_and_wrong_phase_calls_are_errors_not_crashes() {
        for (model, controller) in KINDS {
            let c = instantiate(model, controller);
            // SAFETY: every call gets the handle fmi2Instantiate gave, or one it never gave
            unsafe {
                assert_eq!(
                    fmi2DoStep(c, 0.0, 0.01, 1),
                    ERROR,
                    "a step before initialisation"
                );
                assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 1e300, 0, 0.0), ERROR);
                assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
                assert_eq!(fmi2EnterInitializationMode(c), OK);
                assert_eq!(fmi2ExitInitializationMode(c), OK);
                assert_eq!(fmi2DoStep(c, 0.0, 0.01, 1), OK);
                for (t, h) in [(0.01, 1e300), (0.01, f64::NAN), (0.01, -0.01), (-1.0, 0.01)] {
                    assert_eq!(fmi2DoStep(c, t, h, 1), ERROR, "t {t}, h {h}");
                }
                assert_eq!(fmi2DoStep(c, 0.01, 0.01, 1), OK);
                assert_eq!(fmi2Terminate(c), OK);
                assert_eq!(
                    fmi2DoStep(c, 0.02, 0.01, 1),
                    ERROR,
                    "a step after terminate"
                );
                let (status, last) = x(c);
                assert_eq!(status, OK);
                assert!((last - 0.345).abs() < 1e-3, "{last}");
                assert_eq!(fmi2Reset(c), OK);
                fmi2FreeInstance(c);
                // freed: every call is an error, freeing again is harmless
                assert_eq!(fmi2DoStep(c, 0.02, 0.01, 1), ERROR);
                assert_eq!(x(c).0, ERROR);
                assert_eq!(fmi2Terminate(c), ERROR);
                assert_eq!(fmi2Reset(c), ERROR);
                fmi2FreeInstance(c);
                fmi2FreeInstance(c);
            }
        }
        // handles never given out, null among them
        for bogus in [
            std::ptr::null_mut(),
            usize::MAX as *mut c_void,
            0xdead as *mut c_void,
        ] {
            // SAFETY: the handle is looked up, never dereferenced
            unsafe {
                assert_eq!(fmi2DoStep(bogus, 0.0, 0.01, 1), ERROR);
                assert_eq!(fmi2ExitInitializationMode(bogus), ERROR);
                fmi2FreeInstance(bogus);
            }
        }
    }

    #[test]
    fn handles_are_not_reused() {
        let a = instantiate(ModelKind::Linear, Controller::Article);
        fmi2FreeInstance(a);
        let b = instantiate(ModelKind::Linear, Controller::Article);
        assert_ne!(a, b);
        // SAFETY: handles from fmi2Instantiate
        unsafe {
            assert_eq!(fmi2SetupExperiment(a, 0, 0.0, 0.0, 0, 0.0), ERROR);
            assert_eq!(fmi2SetupExperiment(b, 0, 0.0, 0.0, 0, 0.0), OK);
        }
        fmi2FreeInstance(b);
    }
}
