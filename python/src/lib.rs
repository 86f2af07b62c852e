//! `import djkr`: the Python binding of the djkr library.
//!
//! Every function is thin over [`djkr::api`], the calls the command line makes too, so a
//! function's dict has the keys and numbers of the command's `--json` (or the columns of its
//! CSV table), and [`run`]'s arrays are the datasets of `djkr run`'s `run.h5`.
//!
//! - Arguments: quantities are SI floats or strings with units (`"400Hz"`, `"0.5mm"`); a
//!   float reaches the parser as its shortest round-trip text, so `0.0005` and `"0.0005"` are
//!   the same number. A scenario is a path (`str` without a line break, or `os.PathLike`), a
//!   TOML string, or a dict with the file's structure; `set=` is a dict of `--set` overrides.
//! - Errors: bad input raises `djkr.ScenarioError` (a `ValueError`) with the command line's
//!   message; a run that a budget stopped or that failed raises `RuntimeError` whose `run`
//!   attribute is the run up to there (its summary's `status`, `reason`, `message` say how it
//!   ended); a panic never crosses into Python (it becomes a `RuntimeError`).
//! - Long calls (`run`, `validate`, `resonance`, `sweep`) run on a worker thread with the
//!   interpreter lock released; the main thread polls for signals every [`POLL`] and on Ctrl-C
//!   raises the computation's cancellation flag ([`djkr::cancel`]), waits for the worker to
//!   stop (tens of microseconds of simulation) and raises `KeyboardInterrupt`. Other Python
//!   threads (which Python never interrupts) run them in place, without the lock.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{
    PyKeyboardInterrupt, PyRuntimeError, PyRuntimeWarning, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple, PyType};

use djkr::adhesion::Law;
use djkr::api::{self, ApiError, Arg};
use djkr::cancel::{Cancel, CancelFlag};
use djkr::closed_form::{DeltaAmpForm, BETA_PAPER};
use djkr::dynamics::types::Event;
use djkr::input::{show_limit, InputKind};
use djkr::material::Material;
use djkr::output::table::{Column, Data, Table};
use djkr::output::timeseries::{kind_name, stage_index, SEGMENT, SERIES, STAGE};
use djkr::scenario::parse::{self, ScenarioSource};
use djkr::steady::{Options, Problem};
use djkr::units::Dimension;

create_exception!(
    djkr,
    ScenarioError,
    PyValueError,
    "Bad input: a scenario, an override, an argument or a grid that djkr refuses. The message \
     is the command line's and names the file, key or argument, the value and what is allowed."
);

/// How often the calling thread looks for Ctrl-C while a long call runs.
const POLL: Duration = Duration::from_millis(20);

// ---------------------------------------------------------------------------------------------
// errors, panics, threads

fn api_err(e: ApiError) -> PyErr {
    match e {
        ApiError::Cancelled => PyKeyboardInterrupt::new_err("cancelled"),
        e if e.is_input() => ScenarioError::new_err(e.to_string()),
        e => PyRuntimeError::new_err(e.to_string()),
    }
}

fn input_err(e: impl std::fmt::Display) -> PyErr {
    ScenarioError::new_err(e.to_string())
}

fn panic_text(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

fn panic_err(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    PyRuntimeError::new_err(format!(
        "internal error in djkr (please report): {}",
        panic_text(payload)
    ))
}

/// Run `f` on this thread, a panic becoming a `RuntimeError`.
fn guarded<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|p| Err(panic_err(p)))
}

/// A long call's view of its cancellation flag (all `'static`, so the call can run on the
/// persistent worker thread).
#[derive(Clone, Copy)]
struct Stop {
    token: Cancel,
    flag: &'static AtomicBool,
}

impl Stop {
    /// The token for the solver settings.
    fn token(&self) -> Cancel {
        self.token
    }
    /// The flag itself (a sweep's stop request).
    fn flag(&self) -> &'static AtomicBool {
        self.flag
    }
    fn is_cancelled(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}

type Job = Box<dyn FnOnce() + Send>;

/// The thread that runs the main thread's long calls, started at the first. One thread kept for
/// the process rather than one per call: a new thread's first allocations fault in fresh pages,
/// which cost 5 % of a 10 ms run.
///
/// The worker belongs to the process that started it: a child made by `fork` (multiprocessing)
/// inherits the channel but not the thread, so a process whose id changed starts its own.
fn submit(job: Job) -> PyResult<()> {
    static WORKER: Mutex<Option<(u32, mpsc::Sender<Job>)>> = Mutex::new(None);
    let mut worker = WORKER.lock().unwrap_or_else(|p| p.into_inner());
    let pid = std::process::id();
    if worker.as_ref().is_none_or(|(owner, _)| *owner != pid) {
        let (tx, rx) = mpsc::channel::<Job>();
        std::thread::Builder::new()
            .name("djkr-worker".into())
            .spawn(move || {
                for job in rx {
                    job();
                }
            })
            .map_err(|e| PyRuntimeError::new_err(format!("djkr: no worker thread: {e}")))?;
        *worker = Some((pid, tx));
    }
    let sent = worker.as_ref().map(|(_, tx)| tx.send(job));
    match sent {
        Some(Ok(())) => Ok(()),
        _ => Err(PyRuntimeError::new_err(
            "djkr: the worker thread is not running",
        )),
    }
}

/// True on the interpreter's main thread, the only one that receives KeyboardInterrupt.
fn on_main_thread(py: Python<'_>) -> PyResult<bool> {
    let threading = py.import("threading")?;
    let main = threading.call_method0("main_thread")?.getattr("ident")?;
    let me = threading.call_method0("get_ident")?;
    main.eq(me)
}

/// Run `work` with the interpreter lock released. On the main thread it runs on the worker
/// thread while this one polls for signals every [`POLL`]; on a signal (Ctrl-C) the flag is
/// raised, the worker stops at its next poll (tens of microseconds) and the signal's exception
/// is returned. On other threads, which never receive Ctrl-C, it runs in place. A panic becomes
/// a `RuntimeError`.
fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(Stop) -> Result<T, ApiError> + Send + 'static,
) -> PyResult<T> {
    let guard = CancelFlag::acquire();
    let stop = Stop {
        token: guard.token(),
        flag: guard.flag(),
    };
    if !on_main_thread(py)? {
        return py
            .detach(|| catch_unwind(AssertUnwindSafe(|| work(stop))))
            .map_err(panic_err)?
            .map_err(api_err);
    }
    let (tx, rx) = mpsc::channel();
    submit(Box::new(move || {
        let _ = tx.send(catch_unwind(AssertUnwindSafe(|| work(stop))));
    }))?;
    // Borrowed by the waits below with the lock released, which need it `Sync`.
    let rx = Mutex::new(rx);
    let wait = |timeout: Option<Duration>| {
        let rx = rx.lock().unwrap_or_else(|p| p.into_inner());
        match timeout {
            Some(t) => rx.recv_timeout(t),
            None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
        }
    };
    let result = loop {
        match py.detach(|| wait(Some(POLL))) {
            Ok(Ok(r)) => break r.map_err(api_err),
            Ok(Err(p)) => break Err(panic_err(p)),
            Err(RecvTimeoutError::Disconnected) => {
                break Err(PyRuntimeError::new_err(
                    "djkr: the worker thread ended without a result",
                ))
            }
            Err(RecvTimeoutError::Timeout) => {
                if let Err(signal) = py.check_signals() {
                    guard.cancel();
                    // The flag returns to the pool only once the work has let go of it.
                    let _ = py.detach(|| wait(None));
                    break Err(signal);
                }
            }
        }
    };
    drop(guard);
    result
}

fn warn(py: Python<'_>, messages: &[String]) -> PyResult<()> {
    let category = py.get_type::<PyRuntimeWarning>();
    for m in messages {
        PyErr::warn(
            py,
            &category,
            &std::ffi::CString::new(m.as_str()).unwrap_or_default(),
            1,
        )?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// arguments

/// `djkr.ScenarioTypeError`: bad input of the wrong type (a list where a number goes, an int
/// where a dict goes). A subclass of both `ScenarioError` and `TypeError`, so that `except
/// djkr.ScenarioError` catches every bad input and `except TypeError` still catches a wrong
/// type, as Python's convention has it. Made at first use with Python's `type()`, since an
/// exception class with two bases cannot be declared from Rust.
fn scenario_type_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    static CLASS: PyOnceLock<Py<PyType>> = PyOnceLock::new();
    CLASS
        .get_or_try_init(py, || {
            let ns = PyDict::new(py);
            ns.set_item("__module__", "djkr")?;
            ns.set_item(
                "__doc__",
                "Bad input of the wrong type: both a ScenarioError and a TypeError.",
            )?;
            let bases = PyTuple::new(
                py,
                [py.get_type::<ScenarioError>(), py.get_type::<PyTypeError>()],
            )?;
            let class =
                py.import("builtins")?
                    .getattr("type")?
                    .call1(("ScenarioTypeError", bases, ns))?;
            Ok::<_, PyErr>(class.cast_into::<PyType>()?.unbind())
        })
        .map(|c| c.bind(py))
}

/// A [`scenario_type_error`] with `message`.
fn type_err(message: impl Into<String>) -> PyErr {
    let message = message.into();
    Python::attach(|py| match scenario_type_error(py) {
        Ok(class) => PyErr::from_type(class.clone(), message),
        Err(e) => e,
    })
}

/// The largest text djkr takes from Python in one argument: a scenario (a TOML string, or a dict
/// once written as TOML), `set=` or `grid=` all together. The limit of a scenario file
/// ([`InputKind::Scenario`], 1 MiB), so that no way of passing a scenario is larger than a file.
fn text_limit() -> usize {
    InputKind::Scenario.limit() as usize
}

/// `what` is larger than [`text_limit`]: the same words as for a file that is, after its size
/// when known (`1048577 bytes`, or `2000000 characters` for a string not yet encoded).
fn too_large(what: &str, size: Option<String>) -> PyErr {
    let limit = text_limit();
    let size = match size {
        Some(s) => format!("{s}: "),
        None => String::new(),
    };
    input_err(format!(
        "{what}: {size}larger than {limit} bytes ({}), the limit for a scenario file",
        show_limit(limit as u64)
    ))
}

/// At most 80 characters of `s` (a key or value quoted in a message), `…` marking a cut.
fn quote(s: &str) -> String {
    const MAX: usize = 80;
    match s.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s.to_string(),
    }
}

/// A Python `str` as Rust text; one holding a lone surrogate (which UTF-8 cannot encode) is bad
/// input named `what`.
fn text_of(s: &Bound<'_, PyString>, what: &str) -> PyResult<String> {
    s.extract::<String>().map_err(|_| {
        input_err(format!(
            "{}: not valid Unicode text (a lone surrogate such as '\\ud800')",
            quote(what)
        ))
    })
}

/// The type name of `v`, for messages.
fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// An argument's text: a string as given, a number as its shortest round-trip text.
fn arg_text(v: &Bound<'_, PyAny>, name: &str) -> PyResult<String> {
    if v.is_instance_of::<PyBool>() {
        return Err(type_err(format!(
            "{name}: expected a number or a string with a unit, got a bool"
        )));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return text_of(s, name);
    }
    if v.is_instance_of::<PyFloat>() || v.is_instance_of::<PyInt>() {
        // A Python int has no size limit: 10**10**6 has a million digits (and Python refuses to
        // write one of more than 4300); anything beyond f64's range is as good as infinite.
        if v.is_instance_of::<PyInt>() && v.extract::<f64>().is_err() {
            return Err(input_err(format!(
                "{name}: an integer beyond the range of a 64-bit float (about 1.8e308)"
            )));
        }
        return v.str()?.extract::<String>();
    }
    // numpy scalars and other numbers
    if let Ok(x) = v.extract::<f64>() {
        return Ok(format!("{x:?}"));
    }
    Err(type_err(format!(
        "{name}: expected a number (SI) or a string with a unit, got {}",
        type_name(v)
    )))
}

/// A `set=` value as `--set` takes it: strings as given, booleans `true`/`false`, numbers as
/// their shortest round-trip text.
fn set_value_text(v: &Bound<'_, PyAny>, key: &str) -> PyResult<String> {
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(if b.is_true() { "true" } else { "false" }.into());
    }
    arg_text(v, key)
}

/// An optional dict argument (`set=`, `grid=`): `None`, or a dict.
fn dict_arg<'a, 'py>(
    v: Option<&'a Bound<'py, PyAny>>,
    name: &str,
) -> PyResult<Option<&'a Bound<'py, PyDict>>> {
    match v {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => v.cast::<PyDict>().map(Some).map_err(|_| {
            type_err(format!(
                "{name}: expected a dict of scenario keys, got {}",
                type_name(v)
            ))
        }),
    }
}

/// A key of `set=` or `grid=`: a string.
fn key_text(k: &Bound<'_, PyAny>, name: &str) -> PyResult<String> {
    match k.cast::<PyString>() {
        Ok(s) => text_of(s, name),
        Err(_) => Err(type_err(format!(
            "{name}: keys must be strings such as \"base.amplitude\", got {}",
            type_name(k)
        ))),
    }
}

/// Refuse a `set=` key that `command` takes from elsewhere (`replaced`: key and where its value
/// comes from): an override is honoured or refused, never silently ignored.
fn refuse_replaced(sets: &[String], command: &str, replaced: &[(&str, &str)]) -> PyResult<()> {
    // A malformed override is reported later, where the scenario is built, in the same words
    // as before.
    let Ok(overrides) = api::overrides(sets) else {
        return Ok(());
    };
    match api::replaced_override(&overrides, replaced) {
        Some((key, how)) => Err(input_err(format!(
            "set={{'{key}': ...}}: has no effect on {command}: {how}"
        ))),
        None => Ok(()),
    }
}

/// What `validate` and `resonance` integrate with instead of the scenario's `solver.rtol`.
const STEADY_RTOL: &str = "its steady state is integrated at rtol = 1e-10, as the command \
                           line's default --rtol";

/// `set=` as `KEY=VALUE` texts, at most [`text_limit`] bytes together.
fn set_texts(set: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let mut out = Vec::new();
    let mut bytes = 0;
    if let Some(d) = dict_arg(set, "set")? {
        for (k, v) in d.iter() {
            let key = key_text(&k, "set")?;
            let value = set_value_text(&v, &key)?;
            bytes += key.len() + value.len() + 1;
            if bytes > text_limit() {
                return Err(too_large("set", None));
            }
            out.push(format!("{key}={value}"));
        }
    }
    Ok(out)
}

/// A whole-number argument (`ensemble`, `seed`, `jobs`) in `[min, max]`: an int (or anything
/// with `__index__`, such as a numpy integer), not a bool; `None` when not given.
fn whole_arg(
    v: Option<&Bound<'_, PyAny>>,
    name: &str,
    min: u64,
    max: u64,
) -> PyResult<Option<u64>> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    let range = || {
        input_err(format!(
            "{name} = {}: must be a whole number in [{min}, {max}]",
            quote(&v.str().map(|s| s.to_string()).unwrap_or_default())
        ))
    };
    if v.is_instance_of::<PyBool>() {
        return Err(type_err(format!(
            "{name}: expected a whole number, got a bool"
        )));
    }
    match v.extract::<i128>() {
        Ok(i) if i >= min as i128 && i <= max as i128 => Ok(Some(i as u64)),
        Ok(_) => Err(range()),
        Err(_) if v.is_instance_of::<PyInt>() => Err(range()),
        Err(_) => Err(type_err(format!(
            "{name}: expected a whole number, got {}",
            type_name(v)
        ))),
    }
}

/// A string argument (`method`, `sweep`).
fn str_arg(v: &Bound<'_, PyAny>, name: &str) -> PyResult<String> {
    match v.cast::<PyString>() {
        Ok(s) => text_of(s, name),
        Err(_) => Err(type_err(format!(
            "{name}: expected a string, got {}",
            type_name(v)
        ))),
    }
}

/// A folder argument (`out`): a `str` or `os.PathLike`; `None` when not given.
fn path_arg(v: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<PathBuf>> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Some(PathBuf::from(text_of(s, name)?)));
    }
    v.extract::<PathBuf>().map(Some).map_err(|_| {
        type_err(format!(
            "{name}: expected a path (str or os.PathLike), got {}",
            type_name(v)
        ))
    })
}

/// Where a scenario comes from.
enum Scenario {
    Path(PathBuf),
    Text { text: String, name: &'static str },
}

/// A scenario argument: a dict (written as TOML), a TOML string (one with a line break), a path
/// (a `str` without one, or `os.PathLike`). A dict or string is held to the size of a file
/// ([`text_limit`]).
fn scenario_of(obj: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    if let Ok(d) = obj.cast::<PyDict>() {
        let table = ToToml::default().table(d, "", 0)?;
        let text = toml::to_string(&table)
            .map_err(|e| input_err(format!("<dict>: cannot be written as TOML: {e}")))?;
        if text.len() > text_limit() {
            return Err(too_large(
                "<dict> written as TOML",
                Some(format!("{} bytes", text.len())),
            ));
        }
        return Ok(Scenario::Text {
            text,
            name: "<dict>",
        });
    }
    if let Ok(s) = obj.cast::<PyString>() {
        // Neither a path (at most a few kB) nor a scenario can be longer: refused by its length
        // in characters before it is copied (each is at least a byte), then in bytes.
        let chars = s.len()?;
        if chars > text_limit() {
            return Err(too_large("<string>", Some(format!("{chars} characters"))));
        }
        let s = text_of(s, "<string>")?;
        if s.len() > text_limit() {
            return Err(too_large("<string>", Some(format!("{} bytes", s.len()))));
        }
        // Any valid scenario spans several lines (a [material] table at least); a path has no
        // line break.
        if s.contains('\n') {
            return Ok(Scenario::Text {
                text: s,
                name: "<string>",
            });
        }
        return Ok(Scenario::Path(PathBuf::from(s)));
    }
    if let Ok(p) = obj.extract::<PathBuf>() {
        return Ok(Scenario::Path(p));
    }
    Err(type_err(format!(
        "scenario: expected a path, a TOML string or a dict, got {}",
        type_name(obj)
    )))
}

impl Scenario {
    fn source(&self) -> Result<ScenarioSource, ApiError> {
        Ok(match self {
            Scenario::Path(p) => ScenarioSource::read(p)?,
            Scenario::Text { text, name } => ScenarioSource::parse(text, name, None)?,
        })
    }

    fn material(&self) -> Result<(Material, Law), ApiError> {
        Ok(match self {
            Scenario::Path(p) => parse::material_and_law(p)?,
            Scenario::Text { text, name } => parse::parse_material_and_law(text, name, None)?,
        })
    }
}

/// The deepest nesting of dicts and lists a scenario dict may have: the TOML parser's own limit
/// (toml 0.9 refuses tables, arrays and dotted keys nested 80 deep), so a dict is refused where
/// the same scenario as a file would be, and before the conversion (a recursion) could overflow
/// the stack.
const MAX_DEPTH: usize = 80;

/// Converts a scenario dict into a TOML table, refusing what no scenario file can hold: a
/// container inside itself (a cycle), nesting deeper than [`MAX_DEPTH`], and more text than
/// [`text_limit`] (counted as the conversion goes, from below, so that a dict of a million
/// stages is refused after the first megabyte's worth of them rather than converted whole).
#[derive(Default)]
struct ToToml {
    /// The dicts and lists on the path from the top to the value being converted (their
    /// addresses: a live object's address is its identity).
    open: Vec<usize>,
    /// Bytes the TOML text will take at least: each key and each string its length, each other
    /// value and each list item one byte.
    bytes: usize,
}

impl ToToml {
    /// Count `n` bytes of the TOML text to come.
    fn count(&mut self, n: usize) -> PyResult<()> {
        self.bytes = self.bytes.saturating_add(n);
        if self.bytes > text_limit() {
            return Err(too_large("<dict>", None));
        }
        Ok(())
    }

    /// Enter the container `v` at `key`, `depth` levels down: refused when it is already open
    /// (a cycle) or too deep.
    fn enter(&mut self, v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<()> {
        let id = v.as_ptr() as usize;
        if self.open.contains(&id) {
            return Err(input_err(format!(
                "<dict>: {}: contains itself (a cycle): a scenario is a tree of dicts and lists",
                quote(key)
            )));
        }
        if depth > MAX_DEPTH {
            return Err(input_err(format!(
                "<dict>: {}: nested more than {MAX_DEPTH} deep, the limit of a scenario file",
                quote(key)
            )));
        }
        self.open.push(id);
        Ok(())
    }

    /// A dict with a scenario file's structure as a TOML table (`key` is the dotted path so far).
    fn table(&mut self, d: &Bound<'_, PyDict>, key: &str, depth: usize) -> PyResult<toml::Table> {
        self.enter(d, key, depth)?;
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let k = match k.cast::<PyString>() {
                Ok(s) => text_of(s, &format!("<dict>: {key}: a key"))?,
                Err(_) => {
                    return Err(input_err(format!(
                        "<dict>: {}: keys must be strings, got {}",
                        quote(key),
                        type_name(&k)
                    )))
                }
            };
            self.count(k.len())?;
            let path = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            let value = self.value(&v, &path, depth + 1)?;
            t.insert(k, value);
        }
        self.open.pop();
        Ok(t)
    }

    fn value(&mut self, v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<toml::Value> {
        if let Ok(b) = v.cast::<PyBool>() {
            self.count(1)?;
            return Ok(toml::Value::Boolean(b.is_true()));
        }
        if v.is_instance_of::<PyInt>() {
            self.count(1)?;
            return match v.extract::<i64>() {
                Ok(i) => Ok(toml::Value::Integer(i)),
                Err(_) => match v.extract::<f64>() {
                    Ok(x) => Ok(toml::Value::Float(x)),
                    Err(_) => Err(input_err(format!(
                        "<dict>: {}: an integer beyond the range of a 64-bit float (about 1.8e308)",
                        quote(key)
                    ))),
                },
            };
        }
        if let Ok(s) = v.cast::<PyString>() {
            self.count(s.len()?.max(1))?;
            return Ok(toml::Value::String(text_of(s, &format!("<dict>: {key}"))?));
        }
        if let Ok(d) = v.cast::<PyDict>() {
            return Ok(toml::Value::Table(self.table(d, key, depth)?));
        }
        if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
            self.enter(v, key, depth)?;
            let mut items = Vec::new();
            for (i, x) in v.try_iter()?.enumerate() {
                self.count(1)?;
                items.push(self.value(&x?, &format!("{key}[{i}]"), depth + 1)?);
            }
            self.open.pop();
            return Ok(toml::Value::Array(items));
        }
        if let Ok(x) = v.extract::<f64>() {
            self.count(1)?;
            return Ok(toml::Value::Float(x));
        }
        Err(type_err(format!(
            "<dict>: {}: a {} cannot be a scenario value (numbers, strings, booleans, dicts and lists can)",
            quote(key),
            type_name(v)
        )))
    }
}

fn material_of(material: Option<&Bound<'_, PyAny>>) -> PyResult<(Material, Law)> {
    match material {
        None => Ok(api::default_material()),
        Some(m) => scenario_of(m)?.material().map_err(api_err),
    }
}

// ---------------------------------------------------------------------------------------------
// conversions

fn json_to_py(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None(),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any().unbind(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any().unbind()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any().unbind()
            } else {
                n.as_f64()
                    .unwrap_or(f64::NAN)
                    .into_pyobject(py)?
                    .into_any()
                    .unbind()
            }
        }
        Value::String(s) => PyString::new(py, s).into_any().unbind(),
        Value::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(json_to_py(py, x)?)?;
            }
            l.into_any().unbind()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any().unbind()
        }
    })
}

/// A column as a numpy array (numbers without a copy; text as a numpy array of `str`).
fn column_to_py(py: Python<'_>, data: Data) -> PyResult<Py<PyAny>> {
    Ok(match data {
        Data::F64(v) => PyArray1::from_vec(py, v).into_any().unbind(),
        Data::I64(v) => PyArray1::from_vec(py, v).into_any().unbind(),
        Data::Text(v) => {
            let np = py.import("numpy")?;
            let kwargs = PyDict::new(py);
            kwargs.set_item("dtype", py.get_type::<PyString>())?;
            np.call_method("array", (PyList::new(py, v)?,), Some(&kwargs))?
                .unbind()
        }
    })
}

/// A table as a dict of its columns, in order, by name (the CSV header without the unit).
fn table_to_py(py: Python<'_>, t: Table) -> PyResult<Py<PyDict>> {
    let d = PyDict::new(py);
    for Column { name, data, .. } in t.into_columns() {
        d.set_item(name, column_to_py(py, data)?)?;
    }
    Ok(d.unbind())
}

fn event_to_py<'py>(py: Python<'py>, e: &Event) -> PyResult<Bound<'py, PyDict>> {
    let state = PyDict::new(py);
    for c in SERIES.iter() {
        state.set_item(c.name, c.value(&e.state))?;
    }
    state.set_item(STAGE, stage_index(e.state.stage))?;
    let d = PyDict::new(py);
    d.set_item("kind", kind_name(e.kind))?;
    d.set_item("time", e.time)?;
    d.set_item("stage", stage_index(e.stage))?;
    d.set_item("state", state)?;
    Ok(d)
}

// ---------------------------------------------------------------------------------------------
// Run

/// A time-domain run held in memory (what `djkr run` writes into `run.h5`).
///
/// `t, x_s, v_s, x_b, x_k, delta, a, a_dot, F, G, w` are numpy float64 arrays in SI units and
/// `stage` and `segment` int64 arrays, the datasets of `run.h5` value for value; `events` is a
/// list of dicts (`kind`, `time`, `stage`, `state`), `cycles` and `gaps` dicts of numpy arrays
/// (the `cycles/` and `gaps/` groups), `summary` the content of `summary.json`.
#[pyclass(module = "djkr", frozen)]
struct Run {
    /// Time (s).
    #[pyo3(get)]
    t: Py<PyAny>,
    /// Sphere position, down positive (m).
    #[pyo3(get)]
    x_s: Py<PyAny>,
    /// Sphere velocity, down positive (m/s).
    #[pyo3(get)]
    v_s: Py<PyAny>,
    /// Base displacement, up positive (m).
    #[pyo3(get)]
    x_b: Py<PyAny>,
    /// Far end of the holding spring, down positive (m).
    #[pyo3(get)]
    x_k: Py<PyAny>,
    /// Indentation x_s + x_b (m).
    #[pyo3(get)]
    delta: Py<PyAny>,
    /// Contact radius (m).
    #[pyo3(get)]
    a: Py<PyAny>,
    /// Contact-radius rate, healing positive (m/s).
    #[pyo3(get)]
    a_dot: Py<PyAny>,
    /// Contact force, compressive positive (N).
    #[pyo3(get, name = "F")]
    force: Py<PyAny>,
    /// Energy release rate (J/m²).
    #[pyo3(get, name = "G")]
    g: Py<PyAny>,
    /// Work of adhesion (J/m²).
    #[pyo3(get)]
    w: Py<PyAny>,
    /// Stage index (int64).
    #[pyo3(get)]
    stage: Py<PyAny>,
    /// Segment index (int64): 0 from the start, +1 after each gap of the time series.
    #[pyo3(get)]
    segment: Py<PyAny>,
    /// The gaps of the time series, the HDF5 `gaps/` group: `t_start`, `t_end` (s), `periods`.
    #[pyo3(get)]
    gaps: Py<PyDict>,
    /// Per-period records, the HDF5 `cycles/` group.
    #[pyo3(get)]
    cycles: Py<PyDict>,
    raw_events: Vec<Event>,
    events: OnceLock<Py<PyList>>,
    summary_text: String,
    summary: OnceLock<Py<PyAny>>,
    name: String,
}

/// The names of the time-series arrays, in file order.
fn series_names() -> Vec<&'static str> {
    SERIES
        .iter()
        .map(|c| c.name)
        .chain([STAGE, SEGMENT])
        .collect()
}

#[pymethods]
impl Run {
    /// Every event of the run, in time order: dicts with `kind`, `time` (s), `stage` and
    /// `state` (the time-series values at the event, as in `summary.json`).
    #[getter]
    fn events(&self, py: Python<'_>) -> PyResult<Py<PyList>> {
        if let Some(l) = self.events.get() {
            return Ok(l.clone_ref(py));
        }
        let l = PyList::empty(py);
        for e in &self.raw_events {
            l.append(event_to_py(py, e)?)?;
        }
        let l = l.unbind();
        let _ = self.events.set(l.clone_ref(py));
        Ok(l)
    }

    /// The content of `summary.json` as a dict.
    #[getter]
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        if let Some(s) = self.summary.get() {
            return Ok(s.clone_ref(py));
        }
        let s = py
            .import("json")?
            .call_method1("loads", (self.summary_text.as_str(),))?
            .unbind();
        let _ = self.summary.set(s.clone_ref(py));
        Ok(s)
    }

    /// The time series as a pandas DataFrame (columns `t`, `x_s`, ..., `w`, `stage`, `segment`).
    fn to_pandas(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let pd = py.import("pandas").map_err(|e| {
            pyo3::exceptions::PyImportError::new_err(format!(
                "Run.to_pandas() needs pandas (pip install pandas): {e}"
            ))
        })?;
        let d = PyDict::new(py);
        for name in series_names() {
            d.set_item(name, self.array(name, py))?;
        }
        Ok(pd.call_method1("DataFrame", (d,))?.unbind())
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.t.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "<djkr.Run of {}: {} samples, {} events>",
            self.name,
            self.t.bind(py).len()?,
            self.raw_events.len()
        ))
    }
}

impl Run {
    fn array(&self, name: &str, py: Python<'_>) -> Py<PyAny> {
        match name {
            "t" => &self.t,
            "x_s" => &self.x_s,
            "v_s" => &self.v_s,
            "x_b" => &self.x_b,
            "x_k" => &self.x_k,
            "delta" => &self.delta,
            "a" => &self.a,
            "a_dot" => &self.a_dot,
            "F" => &self.force,
            "G" => &self.g,
            "w" => &self.w,
            "segment" => &self.segment,
            _ => &self.stage,
        }
        .clone_ref(py)
    }

    fn new(py: Python<'_>, rec: api::RunRecord, name: String) -> PyResult<Self> {
        let mut cols: HashMap<String, Data> = rec
            .series
            .into_columns()
            .into_iter()
            .map(|c| (c.name, c.data))
            .collect();
        let mut take = |n: &str| -> PyResult<Py<PyAny>> {
            let data = cols.remove(n).ok_or_else(|| {
                PyRuntimeError::new_err(format!("internal error: no time-series column {n}"))
            })?;
            column_to_py(py, data)
        };
        // Arrays handed to numpy without a copy; read-only views would cost nothing either, but
        // users expect ordinary arrays.
        let run = Run {
            t: take("t")?,
            x_s: take("x_s")?,
            v_s: take("v_s")?,
            x_b: take("x_b")?,
            x_k: take("x_k")?,
            delta: take("delta")?,
            a: take("a")?,
            a_dot: take("a_dot")?,
            force: take("F")?,
            g: take("G")?,
            w: take("w")?,
            stage: take(STAGE)?,
            segment: take(SEGMENT)?,
            gaps: table_to_py(py, rec.gaps)?,
            cycles: table_to_py(py, rec.cycles)?,
            raw_events: rec.events,
            events: OnceLock::new(),
            summary_text: rec.summary,
            summary: OnceLock::new(),
            name,
        };
        Ok(run)
    }
}

// ---------------------------------------------------------------------------------------------
// functions

/// Run a scenario with the time-domain simulator (`djkr run`).
#[pyfunction]
#[pyo3(signature = (scenario, set = None, out = None))]
fn run(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    set: Option<&Bound<'_, PyAny>>,
    out: Option<&Bound<'_, PyAny>>,
) -> PyResult<Run> {
    let (scn, sets, out) = guarded(|| {
        Ok((
            scenario_of(scenario)?,
            set_texts(set)?,
            path_arg(out, "out")?,
        ))
    })?;
    let (rec, name) = interruptible(py, move |stop| {
        let source = scn.source()?;
        let mut s = source.scenario(&api::overrides(&sets)?)?;
        s.solver.cancel = stop.token();
        // A run that ended early keeps what it computed: it travels with its message to
        // become the exception's `run`.
        let rec = match api::run(&s, out.as_deref()) {
            Ok(rec) => Ok(rec),
            Err(e @ ApiError::Ended { .. }) => {
                let message = e.to_string();
                match e {
                    ApiError::Ended { record, .. } => Err((message, record)),
                    e => return Err(e),
                }
            }
            Err(e) => return Err(e),
        };
        Ok((rec, s.source_name.clone()))
    })?;
    guarded(|| match rec {
        Ok(rec) => Run::new(py, rec, name),
        Err((message, record)) => Err(ended_err(py, message, Run::new(py, *record, name)?)),
    })
}

/// The `RuntimeError` of a run that a budget stopped or that failed mid-way, with the run up to
/// there as its `run` attribute (`summary["status"]`, `["reason"]` and `["message"]` say how
/// it ended).
fn ended_err(py: Python<'_>, message: String, run: Run) -> PyErr {
    let err = PyRuntimeError::new_err(message);
    let attached = Py::new(py, run).and_then(|r| err.value(py).setattr("run", r));
    match attached {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// One imposed-area cycle (`djkr cycle --json`).
#[pyfunction]
#[pyo3(signature = (freq, a_mean, a_amp, material = None))]
fn cycle(
    py: Python<'_>,
    freq: &Bound<'_, PyAny>,
    a_mean: &Bound<'_, PyAny>,
    a_amp: &Bound<'_, PyAny>,
    material: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    guarded(|| {
        let (m, law) = material_of(material)?;
        let (f, am, aa) = (
            arg_text(freq, "freq")?,
            arg_text(a_mean, "a_mean")?,
            arg_text(a_amp, "a_amp")?,
        );
        let r = py
            .detach(|| {
                api::cycle(
                    &m,
                    &law,
                    Arg::new("freq", &f),
                    Arg::new("a_mean", &am),
                    Arg::new("a_amp", &aa),
                )
            })
            .map_err(input_err)?;
        warn(py, &r.notes)?;
        let v = r.json();
        api::check_finite(&v).map_err(api_err)?;
        json_to_py(py, &v)
    })
}

/// The pull-off for a vibration (`djkr pulloff --json`).
#[pyfunction]
#[pyo3(signature = (freq, a_amp, method = None, beta = None, material = None))]
fn pulloff(
    py: Python<'_>,
    freq: &Bound<'_, PyAny>,
    a_amp: &Bound<'_, PyAny>,
    method: Option<&Bound<'_, PyAny>>,
    beta: Option<&Bound<'_, PyAny>>,
    material: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    guarded(|| {
        let method = match method {
            Some(m) if !m.is_none() => str_arg(m, "method")?,
            _ => "exact".to_string(),
        };
        let method = method.as_str();
        if beta.is_some() && method != "approx" {
            return Err(input_err(format!(
                "beta has no effect with method = \"{method}\": leave it out"
            )));
        }
        let (m, law) = material_of(material)?;
        let omega = api::omega_from("freq", &arg_text(freq, "freq")?).map_err(input_err)?;
        let aa = api::non_negative_quantity("a_amp", &arg_text(a_amp, "a_amp")?, Dimension::Length)
            .map_err(input_err)?;
        let how = match method {
            "exact" => api::PullOffMethod::Exact { a_amp: aa },
            "approx" => api::PullOffMethod::Approx {
                a_amp: aa,
                beta: match beta {
                    Some(b) => api::positive_quantity(
                        "beta",
                        &arg_text(b, "beta")?,
                        Dimension::Dimensionless,
                    )
                    .map_err(input_err)?,
                    None => BETA_PAPER,
                },
                form: DeltaAmpForm::Derived,
            },
            "yi" => api::PullOffMethod::Yi {
                delta_amp: djkr::comparators::yi_indentation_amplitude_from_area_amplitude(&m, aa),
            },
            "shui" => return Err(input_err(
                "method = \"shui\": Shui et al.'s eq. (5) needs the sphere's mass, the damping \
                     and the base amplitude, which djkr.pulloff does not take; use the command \
                     line: djkr pulloff --method shui --mass M --damping C --base-amp X",
            )),
            other => {
                return Err(input_err(format!(
                    "method = \"{other}\": must be \"exact\", \"approx\" or \"yi\""
                )))
            }
        };
        let r = py
            .detach(|| api::pull_off(&m, &law, omega, how))
            .map_err(input_err)?;
        warn(py, &r.warnings)?;
        let v = r.json();
        api::check_finite(&v).map_err(api_err)?;
        json_to_py(py, &v)
    })
}

/// The periodic steady state compared with the predictors (`djkr validate --json`).
#[pyfunction]
#[pyo3(signature = (scenario, set = None))]
fn validate(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    set: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let (scn, sets) = guarded(|| Ok((scenario_of(scenario)?, set_texts(set)?)))?;
    refuse_replaced(&sets, "validate", &[("solver.rtol", STEADY_RTOL)])?;
    let report = interruptible(py, move |stop| {
        let source = scn.source()?;
        let mut s = source.scenario(&api::overrides(&sets)?)?;
        s.solver.cancel = stop.token();
        let r = api::validate(&s, &Options::default())
            .map_err(|e| ApiError::from_steady(source.name(), e))?;
        if stop.is_cancelled() {
            return Err(ApiError::Cancelled);
        }
        Ok(r)
    })?;
    guarded(|| {
        let v = api::finite_json(&report).map_err(api_err)?;
        if let Some(e) = api::force_balance_violation(&report) {
            warn(py, &[e])?;
        }
        json_to_py(py, &v)
    })
}

/// The frequency response by continuation (`djkr resonance`): the columns of `resonance.csv`.
#[pyfunction]
#[pyo3(signature = (scenario, freq, sweep = None, set = None))]
fn resonance(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    freq: &Bound<'_, PyAny>,
    sweep: Option<&Bound<'_, PyAny>>,
    set: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyDict>> {
    let (scn, sets, range_text) = guarded(|| {
        let range_text = if let Ok(s) = freq.cast::<PyString>() {
            text_of(s, "freq")?
        } else {
            // At most one value more than needed: an endless iterator is not read forever.
            let parts: Vec<Bound<'_, PyAny>> = freq
                .try_iter()
                .and_then(|it| it.take(4).collect::<PyResult<Vec<_>>>())
                .map_err(|_| type_err("freq: expected (start, stop, n)"))?;
            let [lo, hi, n] = parts.as_slice() else {
                return Err(input_err(format!(
                    "freq: expected (start, stop, n), got {} values",
                    parts.len()
                )));
            };
            format!(
                "{}:{}:{}",
                arg_text(lo, "freq")?,
                arg_text(hi, "freq")?,
                arg_text(n, "freq")?
            )
        };
        Ok((scenario_of(scenario)?, set_texts(set)?, range_text))
    })?;
    refuse_replaced(
        &sets,
        "resonance",
        &[
            ("solver.rtol", STEADY_RTOL),
            ("base.frequency", "the frequencies come from freq="),
        ],
    )?;
    let sweep = match sweep {
        Some(s) if !s.is_none() => str_arg(s, "sweep")?,
        _ => "both".to_string(),
    };
    let which = api::Sweeps::parse("sweep", &sweep).map_err(api_err)?;
    let table = interruptible(py, move |stop| {
        let freqs = api::range(
            "freq",
            &range_text,
            Dimension::Frequency,
            api::limits::RESONANCE_FREQUENCIES,
        )?;
        let source = scn.source()?;
        let mut s = source.scenario(&api::overrides(&sets)?)?;
        s.solver.cancel = stop.token();
        let (problem, start) =
            Problem::from_plan(&s.plan()).map_err(|e| ApiError::from_steady(source.name(), e))?;
        let r = api::resonance(
            &problem,
            &start,
            freqs,
            which,
            &Options::default(),
            true,
            &|_, _| {},
        );
        if stop.is_cancelled() {
            return Err(ApiError::Cancelled);
        }
        Ok(r.table())
    })?;
    guarded(|| table_to_py(py, table))
}

/// A study over scenario keys (`djkr sweep`): the columns of `sweep.csv`.
#[pyfunction]
#[pyo3(signature = (scenario, grid = None, ensemble = None, seed = None, jobs = None))]
fn sweep(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    grid: Option<&Bound<'_, PyAny>>,
    ensemble: Option<&Bound<'_, PyAny>>,
    seed: Option<&Bound<'_, PyAny>>,
    jobs: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyDict>> {
    let (scn, axes, ensemble, seed, jobs) = guarded(|| {
        let mut axes = Vec::new();
        let mut bytes = 0;
        if let Some(g) = dict_arg(grid, "grid")? {
            for (k, v) in g.iter() {
                let key = key_text(&k, "grid")?;
                let axis = format!("{key}={}", spec_text(&v, &key)?);
                bytes += axis.len();
                if bytes > text_limit() {
                    return Err(too_large("grid", None));
                }
                axes.push(axis);
            }
        }
        let whole =
            |v, name| whole_arg(v, name, 0, usize::MAX as u64).map(|w| w.map(|w| w as usize));
        Ok((
            scenario_of(scenario)?,
            axes,
            whole(ensemble, "ensemble")?,
            whole_arg(seed, "seed", 0, u64::MAX)?.unwrap_or(0),
            whole(jobs, "jobs")?,
        ))
    })?;
    if jobs == Some(0) {
        return Err(input_err(
            "jobs = 0: must be a whole number >= 1 (runs at a time)",
        ));
    }
    let table = interruptible(py, move |stop| {
        let source = scn.source()?;
        api::sweep(
            source,
            &axes,
            ensemble.map(|m| (m, seed)),
            jobs.unwrap_or(0),
            Some(stop.flag()),
        )
    })?;
    guarded(|| table_to_py(py, table))
}

/// Fit scenario keys to measured data (`djkr fit`): the content of `fit.json`. `data` is a path
/// to a CSV file or a pandas DataFrame with the same column names (`base.amplitude [um]`,
/// `pull_off_amplification [1]`, `sigma [1]`); `free` a list of `"KEY"` or `"KEY=LO:HI"`.
#[pyfunction]
#[pyo3(signature = (data, scenario, free, observable = None, set = None, ensemble = None, seed = None, jobs = None))]
#[allow(clippy::too_many_arguments)]
fn fit(
    py: Python<'_>,
    data: &Bound<'_, PyAny>,
    scenario: &Bound<'_, PyAny>,
    free: &Bound<'_, PyAny>,
    observable: Option<&Bound<'_, PyAny>>,
    set: Option<&Bound<'_, PyAny>>,
    ensemble: Option<&Bound<'_, PyAny>>,
    seed: Option<&Bound<'_, PyAny>>,
    jobs: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    type Args = (
        Scenario,
        (String, String),
        Vec<String>,
        Option<String>,
        Vec<String>,
        Option<usize>,
        u64,
        Option<usize>,
    );
    let (scn, (text, name), free, observable, set, ensemble, seed, jobs): Args = guarded(|| {
        let data = if data.hasattr("to_csv")? {
            let kw = PyDict::new(py);
            kw.set_item("index", false)?;
            let t: String = data.call_method("to_csv", (), Some(&kw))?.extract()?;
            (t, "<DataFrame>".to_string())
        } else if let Ok(p) = data.extract::<PathBuf>() {
            let name = p.display().to_string();
            let t = std::fs::read_to_string(&p)
                .map_err(|e| input_err(format!("{name}: cannot read the data file: {e}")))?;
            (t, name)
        } else {
            return Err(type_err(format!(
                "data: expected a path or a pandas DataFrame, got {}",
                type_name(data)
            )));
        };
        let free: Vec<String> = if free.is_instance_of::<PyString>() {
            vec![str_arg(free, "free")?]
        } else {
            let mut v = Vec::new();
            for x in free.try_iter()? {
                v.push(str_arg(&x?, "free")?);
            }
            v
        };
        let observable = match observable {
            Some(o) if !o.is_none() => Some(str_arg(o, "observable")?),
            _ => None,
        };
        let whole =
            |v, name| whole_arg(v, name, 0, usize::MAX as u64).map(|w| w.map(|w| w as usize));
        Ok((
            scenario_of(scenario)?,
            data,
            free,
            observable,
            set_texts(set)?,
            whole(ensemble, "ensemble")?,
            whole_arg(seed, "seed", 0, u64::MAX)?.unwrap_or(0),
            whole(jobs, "jobs")?,
        ))
    })?;
    if jobs == Some(0) {
        return Err(input_err(
            "jobs = 0: must be a whole number >= 1 (runs at a time)",
        ));
    }
    let v = interruptible(py, move |stop| {
        let source = scn.source()?;
        api::fit(
            source,
            &text,
            &name,
            &free,
            observable.as_deref(),
            &set,
            ensemble.map(|m| (m, seed)),
            jobs.unwrap_or(0),
            Some(stop.flag()),
        )
    })?;
    guarded(|| json_to_py(py, &v))
}

/// A grid value as a sweep SPEC: a string as given (`"10um:60um:6"`, `"10um,30um"`), a list
/// of values joined by commas, a single value alone.
fn spec_text(v: &Bound<'_, PyAny>, key: &str) -> PyResult<String> {
    if v.is_instance_of::<PyString>() {
        return set_value_text(v, key);
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() || v.hasattr("__array__")? {
        let mut items = Vec::new();
        let mut bytes = 0;
        for (i, x) in v.try_iter()?.enumerate() {
            let t = set_value_text(&x?, key)?;
            if t.contains(',') {
                return Err(input_err(format!(
                    "grid: {} value {} '{}' holds a comma, which separates values",
                    quote(key),
                    i + 1,
                    quote(&t)
                )));
            }
            // An array of a billion values is refused at its first megabyte.
            bytes += t.len() + 1;
            if bytes > text_limit() {
                return Err(too_large("grid", None));
            }
            items.push(t);
        }
        return Ok(items.join(","));
    }
    set_value_text(v, key)
}

/// The extension module `djkr._djkr`; `djkr/__init__.py` re-exports it.
#[pymodule(name = "_djkr")]
fn djkr_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ScenarioError", m.py().get_type::<ScenarioError>())?;
    m.add("ScenarioTypeError", scenario_type_error(m.py())?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Run>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(cycle, m)?)?;
    m.add_function(wrap_pyfunction!(pulloff, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(resonance, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    Ok(())
}
