//! `import djkr`: the Python binding of the djkr library.
//!
//! Every function is thin over [`djkr::api`], the calls the command line makes too, so a
//! function's dict has the keys and numbers of the command's `--json` (or the columns of its
//! CSV table), and `run`'s arrays are the datasets of `djkr run`'s `run.h5`.
//!
//! - Arguments: quantities are SI floats or strings with units (`"400Hz"`, `"0.5mm"`); a
//!   float reaches the parser as its shortest round-trip text, so `0.0005` and `"0.0005"` are
//!   the same number. A scenario is a path (`str` without a line break, or `os.PathLike`), a
//!   TOML string, or a dict with the file's structure; `set=` is a dict of `--set` overrides.
//! - Help: each function's and class's doc comment is its Python docstring (numpydoc: parameters
//!   with units, returns, raises, an example); `djkr/__init__.pyi` holds the same text, generated
//!   by `python python/tests/test_docs.py --write` and checked by that test.
//! - Errors: bad input raises `djkr.ScenarioError` (a `ValueError`) with the command line's
//!   message in Python's words (`PyWords`: `set={'base.amplitude': '-1um'}`, not
//!   `--set base.amplitude=-1um`); an `out=` folder that refuses the run before it starts
//!   (a clash without `force=True`, the disk-space estimate) raises `djkr.OutputFolderError`,
//!   a `ScenarioError` (the command line's exit status 2); a run that a budget stopped or that failed raises
//!   `RuntimeError` whose `run` attribute is the run up to there (its summary's `status`,
//!   `reason`, `message` say how it ended); a panic never crosses into Python (it becomes a
//!   `RuntimeError`).
//! - Long calls (`run`, `validate`, `resonance`, `sweep`) run on a worker thread with the
//!   interpreter lock released; the main thread polls for signals every `POLL` (20 ms) and on
//!   Ctrl-C raises the computation's cancellation flag ([`djkr_core::cancel`]), waits for the worker to
//!   stop (tens of microseconds of simulation) and raises `KeyboardInterrupt`. Other Python
//!   threads (which Python never interrupts) run them in place, without the lock.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use numpy::{PyArray1, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{
    PyKeyboardInterrupt, PyRuntimeError, PyRuntimeWarning, PyTypeError, PyValueError,
};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PySlice, PyString, PyTuple, PyType};

use djkr::api;
use djkr::error::Error as ApiError;
use djkr::input::{show_limit, InputKind};
use djkr::output::timeseries::{self, kind_name, stage_index, SEGMENT, SERIES, STAGE};
use djkr::output::{Column, Data, Table};
use djkr::scenario::overrides::Override;
use djkr::scenario::overrides::SetKey;
use djkr::scenario::parse::{self, ScenarioSource, Tree};
use djkr::sweep::{point_stats, points_table};
use djkr::sweep::{Axis, Ensemble, KeyCell, KeyColumn, Row, RunNumbers, SpecError, SweepError};
use djkr_core::adhesion::Law;
use djkr_core::cancel::{Cancel, CancelFlag};
use djkr_core::dynamics::Event;
use djkr_core::material::Material;
use djkr_core::steady::{Options, Problem};
use djkr_core::text::excerpt;
use djkr_core::units::Dimension;

create_exception!(
    djkr,
    ScenarioError,
    PyValueError,
    "Bad input: a scenario, an override, an argument or a grid that djkr refuses.\n\n\
     A ValueError. The message is the command line's, in Python's words: it names the file or \
     the\nargument (``set={'base.amplitude': '-1um'}``, ``grid=``, ``freq``), the key, the value \
     and what is\nallowed. Every function raises it before any work starts when it can: a \
     sweep checks every\npoint first.\n\nExamples\n--------\n>>> try:\n...     \
     djkr.run(\"scenarios/impacts.toml\", set={\"base.amplitud\": \"30um\"})\n... except \
     djkr.ScenarioError as e:\n...     print(e)   # set={'base.amplitud': ...}: unknown key; ..."
);

create_exception!(
    djkr,
    OutputFolderError,
    ScenarioError,
    "The ``out=`` folder refused the run before it started (a ScenarioError).\n\n\
     As the command line, which exits with status 2 for these: a file djkr did not write at a \
     name the\nrun publishes (``run.h5``, ``summary.json``, ...: pass ``force=True`` to \
     overwrite it, nothing\nelse in the folder is touched), a name there that is not a regular \
     file, a path that is not a\nfolder, another djkr run or sweep writing into it, or output \
     that would not fit the free disk\nspace. Nothing has run and no result was written. \
     A failure to write once the run has started\nis a ``RuntimeError``.\n\nExamples\n\
     --------\n>>> try:\n...     djkr.run(\"scenarios/impacts.toml\", out=\"results\")\n\
     ... except djkr.OutputFolderError as e:\n...     print(e)   # out: results: summary.json \
     is already there and not written by djkr: ..."
);

/// How often the calling thread looks for Ctrl-C while a long call runs.
const POLL: Duration = Duration::from_millis(20);

// ---------------------------------------------------------------------------------------------
// errors, panics, threads

/// A library error as Python's exception, in Python's words ([`PyWords`]): a malformed or
/// unknown `set=` key is `set={'base.amplitud': ...}: unknown key; ...` (its value plays no
/// part), every other override is named with its value, `set={'base.amplitude': '-1um'}: ...`.
fn api_err(e: ApiError) -> PyErr {
    let text = e.in_words(&PyWords::default());
    match e {
        ApiError::Cancelled => PyKeyboardInterrupt::new_err("cancelled"),
        e if e.is_output_refusal() => OutputFolderError::new_err(text),
        e if e.is_input() => ScenarioError::new_err(text),
        _ => PyRuntimeError::new_err(text),
    }
}

/// Python's words for the library's errors ([`djkr::error::Words`]): an input is the keyword
/// argument that gives it (`a_amp`), overrides are `set={'K': V}` (a value as Python writes it),
/// a sweep's axis is `grid={'K': ...}`.
#[derive(Default)]
struct PyWords {
    /// The keys a sweep's `grid=` sets: their overrides are named `grid={...}`, the others
    /// `set={...}`.
    grid: Vec<String>,
}

impl djkr::error::Words for PyWords {
    fn input(&self, name: &str) -> String {
        match name {
            // An argument named alone in a sentence (`set= does not add stages`).
            "set" | "grid" | "ensemble" | "seed" | "samples" | "sigma" => format!("{name}="),
            "force" => "force=True".into(),
            // The command line's --no-repeats.
            "no_repeats" => "repeats=False".into(),
            "out" | "resume" => format!("{name}="),
            _ => name.to_string(),
        }
    }
    fn overrides(&self, items: &[String]) -> String {
        // Consecutive overrides of one argument together: `set={...} grid={...}`.
        let mut groups: Vec<(&str, Vec<String>)> = Vec::new();
        for i in items {
            let (k, item) = match i.split_once('=') {
                Some((k, v)) => (k, format!("'{k}': {}", python_value(v))),
                None => (i.as_str(), format!("'{i}': ...")),
            };
            let arg = if self.grid.iter().any(|g| g == k) {
                "grid"
            } else {
                "set"
            };
            match groups.last_mut() {
                Some((a, v)) if *a == arg => v.push(item),
                _ => groups.push((arg, vec![item])),
            }
        }
        groups
            .iter()
            .map(|(arg, v)| format!("{arg}={{{}}}", v.join(", ")))
            .collect::<Vec<_>>()
            .join(" ")
    }
    fn malformed_override(&self, set: &str) -> String {
        let key = set.split_once('=').map_or(set, |(k, _)| k);
        format!("set={{'{}': ...}}", key.trim())
    }
    fn axis(&self, spec: &str) -> String {
        let key = spec.split_once('=').map_or(spec, |(k, _)| k);
        format!("grid={{'{}': ...}}", key.trim())
    }
    fn input_value(&self, name: &str, value: &str) -> String {
        match name {
            // `KEY=SPEC` axes, one or several (space-separated): named by their keys, as a
            // `grid=` is.
            "candidates" => {
                let keys: Vec<String> = value
                    .split(' ')
                    .filter_map(|a| a.split_once('='))
                    .map(|(k, _)| format!("'{}': ...", k.trim()))
                    .collect();
                format!("candidates={{{}}}", keys.join(", "))
            }
            _ => format!("{name} = {value}"),
        }
    }
}

/// An override's value as Python writes it: `True`/`False`, a number as it is, text quoted.
fn python_value(v: &str) -> String {
    match v {
        "true" => "True".into(),
        "false" => "False".into(),
        _ if v.parse::<f64>().is_ok() => v.into(),
        _ if v.contains('\'') => format!("\"{v}\""),
        _ => format!("'{v}'"),
    }
}

fn input_err(e: impl std::fmt::Display) -> PyErr {
    ScenarioError::new_err(djkr::error::render(&e.to_string(), &PyWords::default()))
}

/// A quantity argument (a number, or a string with a unit) for the request field `name`.
fn quantity(v: &Bound<'_, PyAny>, name: &str, dim: Dimension) -> PyResult<api::Quantity> {
    api::Quantity::parse(name, &arg_text(v, name)?, dim).map_err(input_err)
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
                "Bad input of the wrong type (a list where a number goes, an int where a dict \
                 goes):\ncaught by ``except ScenarioError`` and by ``except TypeError``.",
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

/// A Python `str` as Rust text; one holding a lone surrogate (which UTF-8 cannot encode) is bad
/// input named `what`.
fn text_of(s: &Bound<'_, PyString>, what: &str) -> PyResult<String> {
    s.extract::<String>().map_err(|_| {
        input_err(format!(
            "{}: not valid Unicode text (a lone surrogate such as '\\ud800')",
            excerpt(what)
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
    let Ok(overrides) = Override::parse_all(sets) else {
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
            excerpt(&v.str().map(|s| s.to_string()).unwrap_or_default())
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

/// A flag argument (`force`): `True` or `False`, `None` (not given) being `False`; a bool, not
/// a truthy value (`force="no"` is not read as yes).
fn bool_arg(v: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<bool> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(false);
    };
    match v.cast::<PyBool>() {
        Ok(b) => Ok(b.is_true()),
        Err(_) => Err(type_err(format!(
            "{name}: expected True or False, got {}",
            type_name(v)
        ))),
    }
}

/// A folder argument (`out`): a `str` or `os.PathLike`; `None` when not given.
fn path_arg(v: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<PathBuf>> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    let path = if let Ok(s) = v.cast::<PyString>() {
        PathBuf::from(text_of(s, name)?)
    } else {
        v.extract::<PathBuf>().map_err(|_| {
            type_err(format!(
                "{name}: expected a path (str or os.PathLike), got {}",
                type_name(v)
            ))
        })?
    };
    match api::path_length_error(&path) {
        Some(e) => Err(input_err(format!("{name} = {e}"))),
        None => Ok(Some(path)),
    }
}

/// A scenario's path, refused when no system call would take it
/// ([`api::path_length_error`]).
fn scenario_path(p: PathBuf) -> PyResult<Scenario> {
    match api::path_length_error(&p) {
        Some(e) => Err(input_err(format!("scenario = {e}"))),
        None => Ok(Scenario::Path(p)),
    }
}

/// Where a scenario comes from.
enum Scenario {
    Path(PathBuf),
    Text {
        text: String,
        name: &'static str,
    },
    /// A dict, as the library's format-neutral tree (named `<dict>`).
    Tree(Vec<(String, Tree)>),
}

/// A scenario argument: a dict (the library's [`Tree`]), a TOML string (one with a line break), a path
/// (a `str` without one, or `os.PathLike`). A dict or string is held to the size of a file
/// ([`text_limit`]).
fn scenario_of(obj: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    if let Ok(d) = obj.cast::<PyDict>() {
        return Ok(Scenario::Tree(ToTree::default().table(d, "", 0)?));
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
        return scenario_path(PathBuf::from(s));
    }
    if let Ok(p) = obj.extract::<PathBuf>() {
        return scenario_path(p);
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
            Scenario::Tree(top) => ScenarioSource::from_tree(top.clone(), "<dict>", None)?,
        })
    }

    fn material(&self) -> Result<(Material, Law), ApiError> {
        Ok(match self {
            Scenario::Path(p) => parse::material_and_law(p)?,
            Scenario::Text { text, name } => parse::parse_material_and_law(text, name, None)?,
            Scenario::Tree(top) => {
                ScenarioSource::from_tree(top.clone(), "<dict>", None)?.material_and_law()?
            }
        })
    }
}

/// The deepest nesting of dicts and lists a scenario dict may have: the library's limit for a
/// tree (that of a scenario file), checked here before the conversion (a recursion) could
/// overflow the stack.
const MAX_DEPTH: usize = parse::MAX_TREE_DEPTH;

/// Converts a scenario dict into the library's [`Tree`], refusing what no scenario file can
/// hold: a container inside itself (a cycle), nesting deeper than [`MAX_DEPTH`], and more than
/// [`text_limit`] bytes of keys and values (counted as the conversion goes, from below, so that
/// a dict of a million stages is refused after the first megabyte's worth of them rather than
/// converted whole; the library holds the whole to the same limit as a file).
#[derive(Default)]
struct ToTree {
    /// The dicts and lists on the path from the top to the value being converted (their
    /// addresses: a live object's address is its identity).
    open: Vec<usize>,
    /// Bytes a scenario file would take at least: each key and each string its length, each
    /// other value and each list item one byte.
    bytes: usize,
}

impl ToTree {
    /// Count `n` bytes of the scenario file's text to come.
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
                excerpt(key)
            )));
        }
        if depth > MAX_DEPTH {
            return Err(input_err(format!(
                "<dict>: {}: nested more than {MAX_DEPTH} deep, the limit of a scenario file",
                excerpt(key)
            )));
        }
        self.open.push(id);
        Ok(())
    }

    /// A dict with a scenario file's structure as a table (`key` is the dotted path so far).
    fn table(
        &mut self,
        d: &Bound<'_, PyDict>,
        key: &str,
        depth: usize,
    ) -> PyResult<Vec<(String, Tree)>> {
        self.enter(d, key, depth)?;
        let mut t = Vec::with_capacity(d.len());
        for (k, v) in d.iter() {
            let k = match k.cast::<PyString>() {
                Ok(s) => text_of(s, &format!("<dict>: {key}: a key"))?,
                Err(_) => {
                    return Err(input_err(format!(
                        "<dict>: {}: keys must be strings, got {}",
                        excerpt(key),
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
            t.push((k, value));
        }
        self.open.pop();
        Ok(t)
    }

    fn value(&mut self, v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<Tree> {
        if let Ok(b) = v.cast::<PyBool>() {
            self.count(1)?;
            return Ok(Tree::Bool(b.is_true()));
        }
        if v.is_instance_of::<PyInt>() {
            self.count(1)?;
            return match v.extract::<i64>() {
                Ok(i) => Ok(Tree::Int(i)),
                Err(_) => match v.extract::<f64>() {
                    Ok(x) => Ok(Tree::Float(x)),
                    Err(_) => Err(input_err(format!(
                        "<dict>: {}: an integer beyond the range of a 64-bit float (about 1.8e308)",
                        excerpt(key)
                    ))),
                },
            };
        }
        if let Ok(s) = v.cast::<PyString>() {
            self.count(s.len()?.max(1))?;
            return Ok(Tree::Text(text_of(s, &format!("<dict>: {key}"))?));
        }
        if let Ok(d) = v.cast::<PyDict>() {
            return Ok(Tree::Table(self.table(d, key, depth)?));
        }
        if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
            self.enter(v, key, depth)?;
            let mut items = Vec::new();
            for (i, x) in v.try_iter()?.enumerate() {
                self.count(1)?;
                items.push(self.value(&x?, &format!("{key}[{i}]"), depth + 1)?);
            }
            self.open.pop();
            return Ok(Tree::List(items));
        }
        if let Ok(x) = v.extract::<f64>() {
            self.count(1)?;
            return Ok(Tree::Float(x));
        }
        Err(type_err(format!(
            "<dict>: {}: a {} cannot be a scenario value (numbers, strings, booleans, dicts and lists can)",
            excerpt(key),
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

/// A time-domain run held in memory: what ``djkr run`` writes into ``run.h5``.
///
/// Made by ``djkr.run``. The time series are numpy arrays of one value per sample, in SI units,
/// equal value for value to the datasets of ``run.h5``: ``t`` (s), ``x_s``, ``v_s``, ``x_b``,
/// ``x_k``, ``delta``, ``a`` (m or m/s), ``a_dot`` (m/s), ``F`` (N), ``G``, ``w`` (J/m^2) as
/// float64, ``stage`` and ``segment`` as int64 (each attribute's help says its sign convention).
/// ``events`` is a list of dicts (``kind``, ``time``, ``stage``, ``state``), ``cycles`` and
/// ``gaps`` dicts of numpy arrays (the ``cycles/`` and ``gaps/`` groups), ``summary`` the
/// content of ``summary.json``. ``len(run)`` is the number of samples.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> r = djkr.run("scenarios/paper-protocol-300hz.toml")
/// >>> r.t.shape, r.F.dtype                     # (samples,), float64
/// >>> r.summary["pull_off"]["force"]           # N
/// >>> r.to_pandas().plot(x="t", y="F")
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
    /// Indentation x_s + x_b, positive compresses (m).
    #[pyo3(get)]
    delta: Py<PyAny>,
    /// Contact radius, 0 out of contact (m).
    #[pyo3(get)]
    a: Py<PyAny>,
    /// Contact-radius rate, healing positive (m/s).
    #[pyo3(get)]
    a_dot: Py<PyAny>,
    /// Contact force on the sphere, compressive positive (N).
    #[pyo3(get, name = "F")]
    force: Py<PyAny>,
    /// Energy release rate, signed (J/m^2).
    #[pyo3(get, name = "G")]
    g: Py<PyAny>,
    /// Work of adhesion w(a_dot) (J/m^2).
    #[pyo3(get)]
    w: Py<PyAny>,
    /// Index of the protocol stage, from 0.
    #[pyo3(get)]
    stage: Py<PyAny>,
    /// Index of the gap-free stretch each sample belongs to: 0 from the start, +1 after each
    /// gap (a span envelope following skipped). Never join samples of different segments.
    #[pyo3(get)]
    segment: Py<PyAny>,
    /// The gaps of the time series, the HDF5 ``gaps/`` group: ``t_start`` and ``t_end`` (s, the
    /// samples either side) and ``periods`` (base periods skipped), one entry per gap.
    #[pyo3(get)]
    gaps: Py<PyDict>,
    /// Per-period records: the datasets of the HDF5 ``cycles/`` group (``index``, ``stage``,
    /// ``t_start``, ``t_end``, ``force_mean``, ...).
    #[pyo3(get)]
    cycles: Py<PyDict>,
    /// The index ranges of the gap-free stretches ([`timeseries::pieces`]).
    piece_ranges: Vec<std::ops::Range<usize>>,
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
    /// Every event of the run, in time order: dicts with ``kind`` (str), ``time`` (s),
    /// ``stage`` (int, from 0) and ``state`` (the time-series values at the event, as in
    /// ``summary.json``).
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

    /// The content of ``summary.json`` as a dict (without ``out=``: ``files`` and
    /// ``file_bytes`` empty). ``summary["pull_off"]`` has ``force`` (N), ``amplification`` (1)
    /// and ``time`` (s) when the sphere detached; a run that never detached had no pull-off
    /// (``pull_off`` empty, ``summary["most_tensile"]`` the most tensile force it saw);
    /// ``summary["status"]`` is ``"ok"``, ``"stopped"`` or ``"failed"``.
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

    /// The time series as a ``pandas.DataFrame``: columns ``t``, ``x_s``, ``v_s``, ``x_b``,
    /// ``x_k``, ``delta``, ``a``, ``a_dot``, ``F``, ``G``, ``w``, ``stage``, ``segment``, one row per
    /// sample (needs pandas).
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

    /// The gap-free stretches of the time series, in time order: one dict per piece with every
    /// array of the run (``t``, ``x_s``, ..., ``F``, ``G``, ``w``, ``stage``, ``segment``)
    /// restricted to it, as numpy views (no copy). Between two pieces envelope following
    /// skipped whole base periods (``gaps``: piece k ends at ``gaps["t_start"][k]``, piece k + 1
    /// starts at ``gaps["t_end"][k]``), so a plot draws each piece as its own line and never
    /// joins two, as ``djkr plot`` does. One piece for a run without gaps.
    ///
    /// >>> for p in r.pieces():
    /// ...     ax.plot(p["t"], p["F"], color="C0")
    fn pieces(&self, py: Python<'_>) -> PyResult<Py<PyList>> {
        let out = PyList::empty(py);
        for r in &self.piece_ranges {
            let slice = PySlice::new(py, r.start as isize, r.end as isize, 1);
            let d = PyDict::new(py);
            for name in series_names() {
                d.set_item(name, self.array(name, py).bind(py).get_item(&slice)?)?;
            }
            out.append(d)?;
        }
        Ok(out.unbind())
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
        let piece_ranges = match cols.get(SEGMENT) {
            Some(Data::I64(seg)) => timeseries::pieces(seg, seg.len()),
            _ => Vec::new(),
        };
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
            piece_ranges,
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

/// Run a scenario with the time-domain simulator, as ``djkr run`` does.
///
/// The run is held in memory; with ``out`` it is also written into a run folder, file for file
/// the one ``djkr run FILE --out DIR`` writes.
///
/// Parameters
/// ----------
/// scenario : str, os.PathLike or dict
///     A scenario file's path (a ``str`` without a line break), a TOML string, or a dict with the
///     file's structure, ``{"version": 1, "material": {...}, "stage": [{...}]}``.
/// set : dict, optional
///     Overrides of scenario keys, as ``--set KEY=VALUE``: ``{"base.amplitude": "30um",
///     "stage[3].speed": 1e-3}``. A value is a number (SI units), a string with a unit or a bool.
/// out : str or os.PathLike, optional
///     A folder for ``run.h5``, ``summary.json`` and the CSV files and figure the scenario's
///     ``[output]`` asks for.
/// force : bool, optional
///     With ``out``: overwrite files of those names that djkr did not write (``djkr run
///     --force``); without it (the default) such a file stops the run before it starts
///     (``OutputFolderError``). Nothing else in the folder is touched.
///
/// Returns
/// -------
/// Run
///     One value per sample in each time-series array (``t`` in s, ``x_s`` and ``delta`` in m,
///     ``F`` in N, ...), the ``events``, the per-period records ``cycles`` and ``summary``, the
///     content of ``summary.json`` (``summary["pull_off"]["force"]`` in N).
///
/// Raises
/// ------
/// ScenarioError
///     Bad input: the message names the file or argument, the key, the value and what is allowed.
///     Also a run whose known sample count (``[output] sample_rate`` > 0 over stages with a
///     ``duration``) would take more than ``solver.max_memory`` (default 2 GiB, 216 bytes a
///     sample): lower the rate or raise ``solver.max_memory``. A run whose sample count is not
///     known before it starts stops with reason ``"memory"`` when it would pass that budget.
/// RuntimeError
///     The run stopped on a budget (``solver.max_steps``, ``max_wall_s``, ``max_events``,
///     ``max_memory``), with ``out`` on low disk space (reason ``"disk"``), or failed
///     mid-way: the exception's ``run`` attribute is the ``Run`` up to there
///     (``e.run.summary["status"]``, ``["reason"]``, ``["message"]``); with ``out``, the folder
///     is written with that status.
/// OutputFolderError
///     A ``ScenarioError``: the ``out`` folder refused the run before it started (a file djkr
///     did not write at a name it publishes, without ``force``; another run writing into it; not
///     a folder; output that would not fit the free disk space). No result was written.
/// KeyboardInterrupt
///     Ctrl-C stops the run within a fraction of a second (with ``out``, the folder is written
///     with reason ``SIGINT``).
///
/// Examples
/// --------
/// >>> import djkr
/// >>> r = djkr.run("scenarios/paper-protocol-300hz.toml", set={"base.amplitude": "30um"})
/// >>> r.summary["pull_off"]["amplification"]   # F_po / (-3/2 pi R w0)
/// >>> df = r.to_pandas()                        # columns t, x_s, ..., stage, segment
#[pyfunction]
// `force` is read by `bool_arg` (a wrong type is a ScenarioTypeError, as for every argument);
// its default shows as `False`, which is what `None` (not given) means.
#[pyo3(
    signature = (scenario, set = None, out = None, force = None),
    text_signature = "(scenario, set=None, out=None, force=False)"
)]
fn run(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    set: Option<&Bound<'_, PyAny>>,
    out: Option<&Bound<'_, PyAny>>,
    force: Option<&Bound<'_, PyAny>>,
) -> PyResult<Run> {
    let (scn, sets, out, force) = guarded(|| {
        Ok((
            scenario_of(scenario)?,
            set_texts(set)?,
            path_arg(out, "out")?,
            bool_arg(force, "force")?,
        ))
    })?;
    if force && out.is_none() {
        return Err(input_err(
            "force=True has no effect without out= (it lets a run overwrite files in its \
             folder): leave it out",
        ));
    }
    let (rec, name) = interruptible(py, move |stop| {
        let source = scn.source()?;
        let mut s = source.scenario(&Override::parse_all(&sets)?)?;
        s.solver.cancel = stop.token();
        // A run that ended early keeps what it computed: it travels with its message to
        // become the exception's `run`.
        let rec = match api::run_into(&s, out.as_deref(), force) {
            Ok(rec) => Ok(rec),
            Err(e @ ApiError::Ended { .. }) => {
                let message = e.in_words(&PyWords::default());
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

/// One imposed-area cycle a(t) = a_mean + a_amp sin(2 pi freq t), as ``djkr cycle --json``.
///
/// The contact radius is imposed; the indentation and force follow from the adhesion law over one
/// period (the paper's Sec. 2.1, the imposed-area method).
///
/// Parameters
/// ----------
/// freq : float or str
///     Frequency (Hz, > 0): ``400`` or ``"400Hz"``, ``"0.4kHz"``.
/// a_mean : float or str
///     Imposed mean contact radius (m): ``0.002`` or ``"2mm"``. May be smaller than ``a_amp``
///     (the contact is then lost for part of the cycle) or negative.
/// a_amp : float or str
///     Amplitude of the contact radius (m, >= 0): ``"0.5mm"``.
/// material : str, os.PathLike or dict, optional
///     A scenario whose ``[material]`` and ``[adhesion]`` are used (default: the paper's Fig. 2
///     set, K 9.33 MPa, R 51 mm, w0 240 mJ/m^2, Gent-Schultz v0 0.0445 mm/s, n 0.531).
///
/// Returns
/// -------
/// dict
///     ``a_mean`` (m, the mean of max(a, 0), the paper's a posteriori a_m), ``a_mean_imposed``
///     (m), ``a_amp`` (m), ``delta_mean`` (m), ``delta_amp`` (m, first-harmonic amplitude
///     hypot(delta_sin, delta_cos)), ``delta_sin`` and ``delta_cos`` (m, its coefficients),
///     ``force_mean`` (N, compressive positive), ``contact_fraction`` (1, of the period in
///     contact) and ``notes`` (list of str: where the answer leaves the model's range; each is
///     also issued as a ``RuntimeWarning``).
///
/// Raises
/// ------
/// ScenarioError
///     An argument out of range or malformed (named as in Python: ``freq = -400: ...``).
///
/// Examples
/// --------
/// >>> import djkr
/// >>> c = djkr.cycle("400Hz", "2mm", "0.5mm")
/// >>> c["force_mean"], c["delta_amp"]           # N, m
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
        let req = api::CycleRequest {
            freq: quantity(freq, "freq", Dimension::Frequency)?,
            a_mean: quantity(a_mean, "a_mean", Dimension::Length)?,
            a_amp: quantity(a_amp, "a_amp", Dimension::Length)?,
        };
        let r = py
            .detach(|| api::cycle(&m, &law, &req))
            .map_err(input_err)?;
        warn(py, &r.notes)?;
        api::check_finite(&r).map_err(api_err)?;
        let v = serde_json::to_value(&r).map_err(|e| input_err(e.to_string()))?;
        json_to_py(py, &v)
    })
}

/// The pull-off force under a vibration of the contact radius, as ``djkr pulloff --json``.
///
/// Parameters
/// ----------
/// freq : float or str
///     Vibration frequency (Hz, > 0): ``400`` or ``"400Hz"``.
/// a_amp : float or str
///     Amplitude of the contact radius (m, >= 0): ``"0.5mm"``.
/// method : {"exact", "approx", "yi"}, optional
///     ``"exact"`` (default): the minimum over a_m of the imposed-area cycle's mean force;
///     ``"approx"``: the paper's closed form with exponent ``beta``; ``"yi"``: Yi et al.'s
///     comparator. (``"shui"`` needs the rig: use the command line.)
/// beta : float, optional
///     The closed form's exponent (``method="approx"`` only; default 2.5, the paper's).
/// material : str, os.PathLike or dict, optional
///     A scenario whose ``[material]`` and ``[adhesion]`` are used (default: the paper's Fig. 2
///     set).
///
/// Returns
/// -------
/// dict
///     ``method`` (str, in words), ``a_mean`` (m, mean contact radius at pull-off),
///     ``delta_mean`` and ``delta_amp`` (m, mean indentation and its first-harmonic amplitude at
///     pull-off), ``force`` (N, negative: tensile), ``amplification`` (1, force over the JKR
///     pull-off -3/2 pi R w0) and ``notes`` (list of str; warnings are also issued as
///     ``RuntimeWarning``).
///
/// Raises
/// ------
/// ScenarioError
///     An argument out of range, an unknown method, or ``beta`` with a method other than
///     ``"approx"``.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> p = djkr.pulloff(400, "0.5mm")
/// >>> p["force"], p["amplification"]            # N, 1
/// >>> djkr.pulloff(400, "0.5mm", method="approx", beta=3.0)["amplification"]
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
                "beta has no effect with method = \"{}\": leave it out",
                excerpt(method)
            )));
        }
        let (m, law) = material_of(material)?;
        let a_amp = quantity(a_amp, "a_amp", Dimension::Length)?;
        let how = match method {
            "exact" => api::PullOff::Exact { a_amp },
            "approx" => api::PullOff::Approx {
                a_amp,
                beta: match beta {
                    Some(b) => Some(quantity(b, "beta", Dimension::Dimensionless)?),
                    None => None,
                },
            },
            "yi" => api::PullOff::Yi { a_amp },
            "shui" => return Err(input_err(
                "method = \"shui\": Shui et al.'s eq. (5) needs the sphere's mass, the damping \
                     and the base amplitude, which djkr.pulloff does not take; use the command \
                     line: djkr pulloff --method shui --mass M --damping C --base-amp X",
            )),
            other => {
                return Err(input_err(format!(
                    "method = \"{}\": must be \"exact\", \"approx\" or \"yi\"",
                    excerpt(other)
                )))
            }
        };
        let req = api::PullOffRequest {
            freq: quantity(freq, "freq", Dimension::Frequency)?,
            method: how,
        };
        let r = py
            .detach(|| api::pull_off(&m, &law, &req))
            .map_err(input_err)?;
        warn(py, &r.warnings)?;
        api::check_finite(&r).map_err(api_err)?;
        let v = serde_json::to_value(&r).map_err(|e| input_err(e.to_string()))?;
        json_to_py(py, &v)
    })
}

/// The periodic steady state compared with the predictors, as ``djkr validate --json``.
///
/// Finds the steady state of the scenario's vibrating contact (shooting on the time-domain model,
/// integrated at rtol 1e-10) and compares it with the imposed-area method, the linear transfer,
/// the paper's printed equations and harmonic balance.
///
/// Parameters
/// ----------
/// scenario : str, os.PathLike or dict
///     A scenario (path, TOML string or dict, as for ``run``) with a ``[base]`` vibration and a
///     mean load.
/// set : dict, optional
///     Overrides of scenario keys, as for ``run``. ``solver.rtol`` is refused (the steady state is
///     integrated at rtol 1e-10).
///
/// Returns
/// -------
/// dict
///     The object of ``djkr validate --json``: ``frequency`` (Hz), ``amplitude`` (m, X_b),
///     ``linear_resonance_frequency`` (Hz), and one dict per method, ``steady``,
///     ``time_domain``, ``imposed_area``, ``linear_transfer``, ``paper_transfer``,
///     ``paper_far_from_resonance``, ``harmonic_balance``, with ``relative_difference`` between
///     them and the ``force_balance`` check (SI units throughout).
///
/// Raises
/// ------
/// ScenarioError
///     Bad input, or a scenario that has no periodic steady state to find (no ``[base]``).
/// RuntimeError
///     The steady-state search failed.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> v = djkr.validate("scenarios/resonance-400hz.toml", set={"base.amplitude": "0.3um"})
/// >>> v["relative_difference"]
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
        let mut s = source.scenario(&Override::parse_all(&sets)?)?;
        s.solver.cancel = stop.token();
        let r = api::validate(&s, &Options::default())
            .map_err(|e| ApiError::from_steady(djkr::error::Source::file(source.name()), e))?;
        if stop.is_cancelled() {
            return Err(ApiError::Cancelled);
        }
        Ok(r)
    })?;
    guarded(|| {
        api::check_finite(&report).map_err(api_err)?;
        let v = serde_json::to_value(&report).map_err(|e| input_err(e.to_string()))?;
        if let Some(e) = api::force_balance_violation(&report) {
            warn(py, &[e])?;
        }
        json_to_py(py, &v)
    })
}

/// The frequency response by continuation, as ``djkr resonance``.
///
/// Steady states at ``n`` evenly spaced frequencies, each started from the last (up, down or
/// both sweeps), with the linear transfer and harmonic balance beside them.
///
/// Parameters
/// ----------
/// scenario : str, os.PathLike or dict
///     A scenario with a ``[base]`` vibration and a mean load (as for ``validate``).
/// freq : (start, stop, n) or str
///     Frequencies (Hz): ``(380, 420, 41)``, ``("0.38kHz", "420Hz", 41)`` or ``"380:420:41"``;
///     ``stop >= start``, ``1 <= n <= 2001``.
/// sweep : {"up", "down", "both"}, optional
///     Direction (default ``"both"``, the two in parallel).
/// set : dict, optional
///     Overrides of scenario keys, as for ``run`` (``solver.rtol`` and ``base.frequency`` are
///     refused: the call sets them).
///
/// Returns
/// -------
/// dict of numpy arrays
///     The columns of ``resonance.csv``, one value per (direction, frequency): ``direction``
///     (str), ``frequency`` (Hz), ``delta_amp_over_xb`` (1, |delta_A / X_b|), ``phase`` (rad),
///     ``delta_mean``, ``delta_sin``, ``delta_cos`` (m), ``force_mean``, ``force_amp`` (N),
///     ``a_mean``, ``a_amp`` (m), ``cycles``, ``residual``, ``contact_lost``, ``method``, the
///     linear transfer's ``linear_delta_amp_over_xb`` and ``linear_phase``, harmonic balance's
///     ``hb_*``, and ``error`` (str, empty when the point converged).
///
/// Raises
/// ------
/// ScenarioError
///     Bad input (``freq`` out of order or too long, an unknown ``sweep``, ...).
///
/// Examples
/// --------
/// >>> import djkr, pandas as pd
/// >>> r = pd.DataFrame(djkr.resonance("scenarios/resonance-400hz.toml", freq=(380, 420, 21)))
/// >>> up = r[r.direction == "up"]
/// >>> djkr.resonance_peak(up.frequency, up.delta_amp_over_xb)   # as djkr resonance finds it
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
        let freqs = api::frequency_range("freq", &range_text)?;
        let source = scn.source()?;
        let mut s = source.scenario(&Override::parse_all(&sets)?)?;
        s.solver.cancel = stop.token();
        let (problem, start) = Problem::from_plan(&s.plan())
            .map_err(|e| ApiError::from_steady(djkr::error::Source::file(source.name()), e))?;
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

/// The resonance peak of sampled data, as ``djkr resonance`` finds it (the ``peak`` of its
/// ``--json``): the highest sample, refined by a parabola through it and its neighbours where
/// the five samples around it lie on one concave branch (never across the jump of a folded
/// curve). A maximum at the first or the last frequency is no peak: the resonance lies beyond
/// the range.
///
/// Parameters
/// ----------
/// frequency : sequence of float
///     Frequencies (Hz), in any order (sorted here).
/// height : sequence of float
///     The response at each, e.g. ``delta_amp_over_xb`` of one sweep direction; non-finite
///     values (points that did not converge) are left out.
///
/// Returns
/// -------
/// dict
///     ``{"frequency": f, "height": h}`` for a peak inside the range, or
///     ``{"no_peak_in_range": {"largest_at": "low" or "high", "frequency": f, "height": h}}``;
///     ``{}`` without finite data.
///
/// Examples
/// --------
/// >>> res = djkr.resonance("scenarios/resonance-400hz.toml", freq=(300, 500, 21))
/// >>> up = res["direction"] == "up"
/// >>> djkr.resonance_peak(res["frequency"][up], res["delta_amp_over_xb"][up])
/// {'frequency': 405.96..., 'height': 13.66...}
#[pyfunction]
fn resonance_peak(py: Python<'_>, frequency: Vec<f64>, height: Vec<f64>) -> PyResult<Py<PyDict>> {
    if frequency.len() != height.len() {
        return Err(input_err(format!(
            "resonance_peak: {} frequencies but {} heights",
            frequency.len(),
            height.len()
        )));
    }
    let mut v: Vec<(f64, f64)> = frequency
        .into_iter()
        .zip(height)
        .filter(|(f, h)| f.is_finite() && h.is_finite())
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let d = PyDict::new(py);
    match api::resonance_peak(&v) {
        Some(Ok(p)) => {
            d.set_item("frequency", p.frequency)?;
            d.set_item("height", p.height)?;
        }
        Some(Err(n)) => {
            let e = PyDict::new(py);
            e.set_item("largest_at", n.largest_at)?;
            e.set_item("frequency", n.frequency)?;
            e.set_item("height", n.height)?;
            d.set_item("no_peak_in_range", e)?;
        }
        None => {}
    }
    Ok(d.unbind())
}

/// A study over scenario keys, as ``djkr sweep``: one run per grid point and ensemble member.
///
/// The grid is the Cartesian product of ``grid``'s values (the first key varies slowest). The
/// keys of ``set`` keep one value each, beside the grid: ``djkr.sweep(F, grid={"K": SPEC},
/// set={"K2": V})`` runs what ``djkr sweep F --set K2=V --set K=SPEC`` runs, rows and columns.
///
/// Parameters
/// ----------
/// scenario : str, os.PathLike or dict
///     The scenario every run starts from (path, TOML string or dict, as for ``run``).
/// grid : dict, optional
///     The swept keys and their values: a list (``["10um", "30um"]``, ``[1e-5, 3e-5]``, a numpy
///     array) or a SPEC string, ``"10um,30um"``, ``"10um:60um:6"`` (linear, ends included) or
///     ``"1um:100um:5log"``. Any key ``set`` takes (``base.frequency``, ``stage[3].speed``,
///     ``adhesion.n``, ``solver.method``, ...).
/// ensemble : int, optional
///     Members per point (>= 1), each with the base phase at shaker-on drawn uniformly in
///     ``[0, 2 pi)`` from (seed, point, member).
/// seed : int, optional
///     Seed of the ensemble's phases (default 0; only with ``ensemble``).
/// jobs : int, optional
///     Runs at a time (default: one per core).
/// set : dict, optional
///     Fixed overrides (one value per key, not in ``grid``), as for ``run``; each is also a
///     column of the rows, as on the command line.
///
/// Returns
/// -------
/// dict of numpy arrays
///     The columns of ``sweep.csv``, one value per run, sorted by (point, member): ``point``,
///     ``member``, one column per ``set`` key then per ``grid`` key (SI value, or text),
///     ``phase`` (rad), ``status`` (``"ok"``, ``"stopped"``, ``"error"``), ``error`` (str),
///     ``pull_off_force`` (N), ``pull_off_amplification`` (1), ``pull_off_time`` (s),
///     ``detached``, ``steps``, ``rhs_evals``, ``wall_s`` (s), and the last cycle's
///     ``force_mean`` (N), ``delta_mean`` and ``delta_amp`` (m). NaN where a run failed.
///     ``pandas.DataFrame(rows)`` makes a table of it; ``djkr.points(rows)`` the per-point
///     statistics.
///
/// Raises
/// ------
/// ScenarioError
///     Bad input, named by its argument: ``grid={'base.amplitude': [..., '-1um', ...]} (point 1):
///     must be a finite number >= 0 (m)``. Every point is checked before any run starts.
/// KeyboardInterrupt
///     Ctrl-C: no new run starts, running ones are abandoned.
///
/// Examples
/// --------
/// >>> import djkr, pandas as pd
/// >>> rows = djkr.sweep("scenarios/paper-protocol-300hz.toml",
/// ...                   grid={"base.amplitude": ["10um", "30um", "60um"]},
/// ...                   set={"stage[2].duration": 0.2}, ensemble=4, seed=1)
/// >>> pd.DataFrame(rows).groupby("base.amplitude").pull_off_amplification.mean()
/// >>> djkr.points(rows)["pull_off_amplification_std"]
#[pyfunction]
#[pyo3(signature = (scenario, grid = None, ensemble = None, seed = None, jobs = None, set = None))]
fn sweep(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    grid: Option<&Bound<'_, PyAny>>,
    ensemble: Option<&Bound<'_, PyAny>>,
    seed: Option<&Bound<'_, PyAny>>,
    jobs: Option<&Bound<'_, PyAny>>,
    set: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyDict>> {
    let (scn, axes, fixed, ensemble, seed, jobs) = guarded(|| {
        // `set=` first, each key an axis of one value: the sweep of `djkr sweep FILE --set K=V
        // --set K2=SPEC`, whose rows have a column for K too.
        let mut axes = Vec::new();
        let mut fixed: Vec<SetKey> = Vec::new();
        for text in set_texts(set)? {
            let axis = Axis::parse(&text).map_err(|e| spec_err("set", &e))?;
            let value = text.split_once('=').map_or("", |(_, v)| v);
            if axis.values.len() != 1 || fixed.contains(&axis.key) {
                return Err(input_err(format!(
                    "set={{'{}': {}}}: {}",
                    axis.key,
                    python_value(&excerpt(value)),
                    if axis.values.len() != 1 {
                        format!(
                            "one value per key in set= ({} here): give the values to sweep in grid=",
                            axis.values.len()
                        )
                    } else {
                        format!("{} is given twice; give each key once", axis.key)
                    }
                )));
            }
            fixed.push(axis.key);
            axes.push(axis);
        }
        let mut bytes = 0;
        if let Some(g) = dict_arg(grid, "grid")? {
            for (k, v) in g.iter() {
                let key = key_text(&k, "grid")?;
                let text = format!("{key}={}", spec_text(&v, &key, "grid")?);
                bytes += text.len();
                if bytes > text_limit() {
                    return Err(too_large("grid", None));
                }
                let axis = Axis::parse(&text).map_err(|e| spec_err("grid", &e))?;
                if fixed.contains(&axis.key) {
                    return Err(input_err(format!(
                        "grid={{'{}': ...}}: {} is also in set=; give each key once (a fixed \
                         value in set=, the values to sweep in grid=)",
                        excerpt(&key),
                        axis.key
                    )));
                }
                axes.push(axis);
            }
        }
        let whole =
            |v, name| whole_arg(v, name, 0, usize::MAX as u64).map(|w| w.map(|w| w as usize));
        Ok((
            scenario_of(scenario)?,
            axes,
            fixed,
            whole(ensemble, "ensemble")?,
            whole_arg(seed, "seed", 0, u64::MAX)?,
            whole(jobs, "jobs")?,
        ))
    })?;
    if jobs == Some(0) {
        return Err(input_err(
            "jobs = 0: must be a whole number >= 1 (runs at a time)",
        ));
    }
    if let (None, Some(s)) = (ensemble, seed) {
        return Err(input_err(format!(
            "seed = {s}: seeds the ensemble's phases; give ensemble=N too"
        )));
    }
    // The axes of `grid=` (the values of `set=` are one-value axes too).
    let grid_keys: Vec<String> = axes
        .iter()
        .filter(|a| !fixed.contains(&a.key))
        .map(|a| a.key.to_string())
        .collect();
    let table = interruptible(py, move |stop| {
        let source = scn.source()?;
        api::sweep(
            source,
            axes,
            ensemble.map(|members| Ensemble {
                members,
                seed: seed.unwrap_or(0),
            }),
            jobs.unwrap_or(0),
            Some(stop.flag()),
        )
        .map_err(|e| sweep_words(e, &fixed, &grid_keys))
    })?;
    guarded(|| table_to_py(py, table))
}

/// A `KEY=SPEC` of `sweep`'s `arg` (`"set"` or `"grid"`) that does not parse, in Python's
/// words: `grid={'base.amplitude': ...}: value 2 '-1um' of the list: ...`.
fn spec_err(arg: &str, e: &SpecError) -> PyErr {
    let key = e.set.split_once('=').map_or(e.set.as_str(), |(k, _)| k);
    input_err(format!(
        "{arg}={{'{}': ...}}: {}",
        excerpt(key.trim()),
        djkr::error::render(&e.message, &PyWords::default())
    ))
}

/// A sweep's error in Python's words, naming the argument a point's key came from: a value
/// of `set=` (`fixed`) as `set={'base.amplitude': '-1um'}: ...`, one of `grid=` as
/// `grid={'base.amplitude': [..., '-1um', ...]} (point 1): ...`.
fn sweep_words(e: ApiError, fixed: &[SetKey], grid_keys: &[String]) -> ApiError {
    let text = match &e {
        ApiError::Sweep(SweepError::Override {
            point,
            set,
            message,
        }) => {
            let (key, value) = set.split_once('=').unwrap_or((set.as_str(), ""));
            let value = python_value(&excerpt(value));
            if fixed.iter().any(|k| k.to_string() == key) {
                format!(
                    "set={{'{key}': {value}}}: {}",
                    djkr::error::render(message, &PyWords::default())
                )
            } else {
                format!(
                    "grid={{'{key}': [..., {value}, ...]}} (point {point}): {}",
                    djkr::error::render(message, &PyWords::default())
                )
            }
        }
        // A point's scenario (`point 3: FILE --set K=V ...: ...`) and the ensemble's clash with
        // a swept `base.phase` name the point's overrides: each by the argument it came from.
        ApiError::Sweep(e @ (SweepError::Point { .. } | SweepError::Ensemble { .. })) => {
            let words = PyWords {
                grid: grid_keys.to_vec(),
            };
            e.in_words(&words)
        }
        ApiError::Spec(s) => format!(
            "grid={{'{}': ...}}: {}",
            excerpt(s.set.split_once('=').map_or(s.set.as_str(), |(k, _)| k)),
            djkr::error::render(&s.message, &PyWords::default())
        ),
        _ => return e,
    };
    ApiError::Invalid(text)
}

/// The per-point statistics of a sweep's rows: the columns of ``points.csv``.
///
/// The same names and values as the ``points.csv`` that ``djkr sweep`` writes for the same sweep:
/// for each point, the statistics of the pull-off force and amplification over its members that
/// ran (status ``"ok"``, finite values).
///
/// Parameters
/// ----------
/// rows : dict of arrays or pandas.DataFrame
///     What ``djkr.sweep`` returned (or a selection of its rows, or ``pandas.DataFrame`` of it).
///     Read: ``point``, ``member``, the swept keys (the columns between ``member`` and
///     ``phase``; numeric or text by dtype), ``status``, ``pull_off_force`` and
///     ``pull_off_amplification``.
///
/// Returns
/// -------
/// dict of numpy arrays
///     One value per point, in point order: ``point``, the swept keys, ``members`` (rows of the
///     point), ``failed`` (of them, runs that did not end ``"ok"``), then for
///     ``pull_off_force`` (N) and ``pull_off_amplification`` (1) each ``_mean``, ``_std``
///     (sample standard deviation, n - 1; NaN below two members), ``_min``, ``_max``, ``_q05``,
///     ``_q50``, ``_q95`` (quantiles as numpy's default, linear). The standard error of the mean
///     is ``_std / sqrt(members - failed)``.
///
/// Raises
/// ------
/// ScenarioError
///     ``rows`` lacks a column, or its columns differ in length or hold the wrong kind of value.
///
/// Examples
/// --------
/// >>> import djkr, numpy as np
/// >>> rows = djkr.sweep("scenarios/paper-protocol-300hz.toml",
/// ...                   grid={"base.amplitude": ["10um", "30um"]}, ensemble=4)
/// >>> p = djkr.points(rows)
/// >>> sem = p["pull_off_amplification_std"] / np.sqrt(p["members"] - p["failed"])
/// >>> # plt.errorbar(p["base.amplitude"], p["pull_off_amplification_mean"], yerr=sem)
#[pyfunction]
#[pyo3(signature = (rows))]
fn points(py: Python<'_>, rows: &Bound<'_, PyAny>) -> PyResult<Py<PyDict>> {
    guarded(|| {
        let (keys, rows) = rows_of(py, rows)?;
        table_to_py(py, points_table(&keys, &point_stats(&rows)))
    })
}

/// The rows of `djkr.sweep` (a dict of its columns, or anything that gives the column names
/// when iterated and a column by `rows[name]`, such as a pandas DataFrame) as the library's
/// rows: the key columns are those between `member` and `phase`, numeric or text by their dtype.
/// Only what `points.csv` reads is taken: `point`, `member`, the keys, `status` and the
/// pull-off force and amplification.
fn rows_of(py: Python<'_>, rows: &Bound<'_, PyAny>) -> PyResult<(Vec<KeyColumn>, Vec<Row>)> {
    const WHAT: &str = "expected the rows of djkr.sweep (its dict of columns, or a pandas \
                        DataFrame of them)";
    if rows.is_instance_of::<PyString>() {
        return Err(type_err(format!("rows: {WHAT}, got a str")));
    }
    let names = rows
        .try_iter()
        .and_then(|it| {
            it.map(|k| k.and_then(|k| k.extract::<String>()))
                .collect::<PyResult<Vec<String>>>()
        })
        .map_err(|_| type_err(format!("rows: {WHAT}, got {}", type_name(rows))))?;
    let at = |n: &str| names.iter().position(|x| x == n);
    let (member_at, phase_at) = match (at("member"), at("phase")) {
        (Some(m), Some(p)) if m < p => (m, p),
        _ => {
            return Err(input_err(format!(
                "rows: no columns 'member' then 'phase' (the swept keys lie between them): {WHAT}"
            )))
        }
    };
    let np = py.import("numpy")?;
    let mut n = None;
    // A column as a numpy array, all of the same length.
    let mut column = |name: &str| -> PyResult<Bound<'_, PyAny>> {
        let c = rows
            .get_item(name)
            .map_err(|_| input_err(format!("rows: no column '{}': {WHAT}", excerpt(name))))?;
        let a = np.call_method1("asarray", (c,))?;
        let len = a.len()?;
        match n {
            None => n = Some(len),
            Some(m) if m != len => {
                return Err(input_err(format!(
                    "rows: column '{}' has {len} values, 'point' {m}: the columns of one sweep \
                     have one value per run each",
                    excerpt(name)
                )))
            }
            _ => {}
        }
        Ok(a)
    };
    let kind = |a: &Bound<'_, PyAny>| -> PyResult<String> {
        a.getattr("dtype")?.getattr("kind")?.extract::<String>()
    };
    let whole = |a: Bound<'_, PyAny>, name: &str| -> PyResult<Vec<usize>> {
        let ok = kind(&a).is_ok_and(|k| k == "i" || k == "u");
        let v: Option<Vec<i64>> = if ok {
            a.call_method0("tolist")?.extract().ok()
        } else {
            None
        };
        v.filter(|v| v.iter().all(|&i| i >= 0))
            .map(|v| v.into_iter().map(|i| i as usize).collect())
            .ok_or_else(|| {
                input_err(format!(
                    "rows: column '{name}' must hold whole numbers >= 0"
                ))
            })
    };
    let floats = |a: Bound<'_, PyAny>, name: &str| -> PyResult<Vec<f64>> {
        a.call_method1("astype", ("float64",))
            .and_then(|a| a.call_method0("tolist"))
            .and_then(|l| l.extract())
            .map_err(|_| {
                input_err(format!(
                    "rows: column '{}' must hold numbers",
                    excerpt(name)
                ))
            })
    };
    let texts = |a: Bound<'_, PyAny>| -> PyResult<Vec<String>> {
        a.call_method0("tolist")?
            .try_iter()?
            .map(|x| x.and_then(|x| Ok(x.str()?.to_string())))
            .collect()
    };
    let point = whole(column("point")?, "point")?;
    let member = whole(column("member")?, "member")?;
    let mut keys = Vec::new();
    let mut cells: Vec<Vec<KeyCell>> = Vec::new();
    for name in &names[member_at + 1..phase_at] {
        let a = column(name)?;
        if matches!(kind(&a)?.as_str(), "f" | "i" | "u") {
            keys.push(KeyColumn {
                name: name.clone(),
                unit: Some("1".into()),
            });
            cells.push(floats(a, name)?.into_iter().map(KeyCell::Num).collect());
        } else {
            keys.push(KeyColumn {
                name: name.clone(),
                unit: None,
            });
            cells.push(texts(a)?.into_iter().map(KeyCell::Text).collect());
        }
    }
    let phase = floats(column("phase")?, "phase")?;
    let status = texts(column("status")?)?;
    let force = floats(column("pull_off_force")?, "pull_off_force")?;
    let amplification = floats(column("pull_off_amplification")?, "pull_off_amplification")?;
    let nan = f64::NAN;
    let mut out = Vec::with_capacity(point.len());
    for i in 0..point.len() {
        let result = match status[i].as_str() {
            "ok" => Ok(RunNumbers {
                pull_off_force: force[i],
                pull_off_amplification: amplification[i],
                pull_off_time: nan,
                detached: false,
                steps: 0,
                rhs_evals: 0,
                force_mean: nan,
                delta_mean: nan,
                delta_amp: nan,
            }),
            "stopped" | "error" => Err(status[i].clone()),
            other => {
                return Err(input_err(format!(
                    "rows: status '{}' (row {i}): must be ok, stopped or error",
                    excerpt(other)
                )))
            }
        };
        out.push(Row {
            point: point[i],
            member: member[i],
            keys: cells.iter().map(|c| c[i].clone()).collect(),
            phase: phase[i],
            stopped: status[i] == "stopped",
            result,
            wall_s: nan,
        });
    }
    Ok((keys, out))
}

/// Estimate scenario keys from measured data, as ``djkr fit``: weighted least squares by
/// Levenberg-Marquardt, each data row predicted by a run of the scenario with that row's
/// conditions set (all cores).
///
/// Parameters
/// ----------
/// data : str, os.PathLike or pandas.DataFrame
///     The measurements: one column per condition named by its scenario key with its unit
///     (``"base.frequency [Hz]"``, ``"base.amplitude [um]"``), one observable column named as in
///     ``sweep.csv`` (``"pull_off_amplification [1]"``, ``"pull_off_force [mN]"``, ...) and
///     optionally ``"sigma [unit of the observable]"``. Without sigma every row weighs the same
///     and the parameters' sigma are scaled by the reduced chi-squared.
/// scenario : str, os.PathLike or dict
///     The scenario every row starts from (path, TOML string or dict, as for ``run``); the free
///     keys start from its values.
/// free : str or list of str
///     The keys to estimate, as on the command line: ``"adhesion.n"`` or bounded
///     ``"adhesion.v_sat=0.01:100"`` (bounds in the key's unit or with units). A positive scale
///     (``adhesion.v0``, ``material.K``) is fitted in log space.
/// observable : str, optional
///     The column to fit when ``data`` has several observables.
/// set : dict, optional
///     Fixed overrides of the scenario, as for ``run``.
/// ensemble : int, optional
///     Members per row (>= 1): a row's prediction is the mean over that many base phases, the
///     same phases (from ``seed``) at every evaluation; the ensemble's standard error joins
///     sigma. For chaotic rigs.
/// seed : int, optional
///     Seed of the ensemble's phases (default 0).
/// jobs : int, optional
///     Runs at a time (default: one per core).
/// max_iterations : int, optional
///     Most iterations (Jacobians) of each run of the optimiser (default 30).
/// starts : int, optional
///     Starting points (default 1): the given one and ``starts - 1`` drawn by Latin hypercube
///     (between a key's bounds, or a factor 10 either side of the start in log space, +-50 %
///     for a linear key); ``r["starts"]`` lists them and the minimum each reached.
/// profile : bool, optional
///     Give every key its profile-likelihood interval (default: only where the model is not
///     linear over one sigma).
/// out : str or os.PathLike, optional
///     A folder for the fit's files, as ``djkr fit --out``: ``fit.json``, ``residuals.csv``,
///     ``fitted.toml``, ``fit.png``, ``fit.svg``.
/// force : bool, optional
///     Overwrite files of those names in ``out`` that djkr did not write (``--force``).
///
/// Returns
/// -------
/// Fit
///     ``r["parameters"]``, ``r["chi2"]``, ... are the content of ``fit.json`` (``r.report``):
///     ``parameters`` (list of dicts with ``key``, ``value``, ``sigma``, ``interval``,
///     ``interval_from``, in the key's own unit, ``unit``, ``initial``), ``covariance`` and
///     ``correlation`` (matrices in the order of ``parameters``), ``chi2``, ``dof``,
///     ``reduced_chi2``, ``aic`` (chi2 + 2k), ``bic`` (chi2 + k ln n), ``converged``,
///     ``termination``, ``iterations``, ``forward_runs``, ``rhs_evals``, ``starts``,
///     ``tolerances``, ``observable``, ``ensemble`` (``members`` and ``seed``, or None) and
///     ``notes``. ``r.parameters``, ``r.sigma``, ``r.intervals`` (dicts by key),
///     ``r.covariance`` (numpy array) and ``r.residuals`` (the columns of ``residuals.csv``;
///     ``r.to_pandas()`` as a DataFrame) are the same as arrays. ``djkr.predict(r, ...)``
///     carries the fit into predictions with uncertainty bands.
///
/// Raises
/// ------
/// ScenarioError
///     Bad data (naming the line and column), unknown or non-numeric free keys, an observable
///     djkr does not produce.
/// KeyboardInterrupt
///     Ctrl-C: no new run starts.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
/// ...              free=["adhesion.v0", "adhesion.n"])
/// >>> r.parameters, r.sigma, r.covariance
/// >>> r.to_pandas()                      # the residuals' table
/// >>> r["aic"], r["notes"]
#[pyfunction]
#[pyo3(
    signature = (data, scenario, free, observable = None, set = None, ensemble = None, seed = None, jobs = None, max_iterations = None, starts = None, profile = None, out = None, force = None),
    text_signature = "(data, scenario, free, observable=None, set=None, ensemble=None, seed=None, jobs=None, max_iterations=30, starts=1, profile=False, out=None, force=False)"
)]
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
    max_iterations: Option<&Bound<'_, PyAny>>,
    starts: Option<&Bound<'_, PyAny>>,
    profile: Option<&Bound<'_, PyAny>>,
    out: Option<&Bound<'_, PyAny>>,
    force: Option<&Bound<'_, PyAny>>,
) -> PyResult<Fit> {
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
            // The one reader of input files: a FIFO or device is refused at once, and a file
            // larger than a fit data file's limit too.
            let t = djkr::input::read_text(&p, InputKind::FitData)
                .map_err(|e| input_err(format!("{}: {e}", name)))?;
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
            // A number or None is not a list of keys: ScenarioTypeError, as every argument's
            // wrong type (the fuzz test met a bare TypeError here).
            let items = free.try_iter().map_err(|_| {
                type_err(format!(
                    "free: expected a key (str) or a list of keys, got {}",
                    type_name(free)
                ))
            })?;
            for x in items {
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
    let extra = guarded(|| {
        let whole = |v, name, lo| whole_arg(v, name, lo, 1_000_000).map(|w| w.map(|w| w as usize));
        let out = path_arg(out, "out")?;
        let force = bool_arg(force, "force")?;
        if force && out.is_none() {
            return Err(input_err(
                "force=True has no effect without out= (it lets a fit overwrite files in its \
                 folder): leave it out",
            ));
        }
        Ok((
            whole(max_iterations, "max_iterations", 0)?.unwrap_or(30),
            whole(starts, "starts", 1)?.unwrap_or(1),
            bool_arg(profile, "profile")?,
            out.map(|o| (o, force)),
        ))
    })?;
    let r = interruptible(py, move |stop| {
        let (max_iterations, starts, profile, out) = extra;
        let source = scn.source()?;
        let free = djkr::fit::FreeKey::parse_all(&free).map_err(ApiError::Invalid)?;
        let data = djkr::fit::FitData::parse(&text, &name, observable.as_deref())
            .map_err(|e| ApiError::Invalid(e.to_string()))?;
        let request = api::FitRequest {
            set: Override::parse_all(&set)?,
            ensemble: ensemble.map(|m| (m, seed)),
            jobs: jobs.unwrap_or(0),
            max_iterations,
            starts,
            profile,
            out,
            ..api::FitRequest::new(source, data, free)
        };
        api::fit(&request, Some(stop.flag()))
    })?;
    guarded(|| Fit::new(py, r))
}

/// The result of ``djkr.fit``: the content of ``fit.json`` and the residuals' table.
///
/// ``r["chi2"]``, ``r["parameters"]``, ... read ``fit.json`` as a dict does (``r.report`` is
/// that dict). ``r.parameters`` maps each key to its estimate and ``r.sigma`` to its standard
/// deviation (``None`` where the fit gives none: not converged, a bound hit, a key the data do
/// not fix, a model that is not linear over one sigma), both in the key's SI unit;
/// ``r.keys`` is their order, ``r.covariance`` the covariance matrix in that order (a numpy
/// array in the keys' units, NaN where a key has no sigma), ``r.intervals`` each key's 68 %
/// interval ``(lo, hi)`` (the profile likelihood's where ``fit.json`` says so).
/// ``r.residuals`` holds the columns of ``residuals.csv`` (numpy arrays; text conditions as
/// lists): ``pandas.DataFrame(r.residuals)`` is its table, as is ``r.to_pandas()``.
///
/// Examples
/// --------
/// >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
/// ...              free=["adhesion.v0", "adhesion.n"])
/// >>> r.parameters["adhesion.n"], r.sigma["adhesion.n"], r.covariance
/// >>> r.to_pandas()[["fitted [1]", "normalized_residual [1]"]]
#[pyclass(module = "djkr", frozen)]
struct Fit {
    /// The content of ``fit.json`` (a dict).
    #[pyo3(get)]
    report: Py<PyAny>,
    /// The keys, in the order of ``covariance``.
    #[pyo3(get)]
    keys: Py<PyAny>,
    /// Each key's estimate (its SI unit).
    #[pyo3(get)]
    parameters: Py<PyAny>,
    /// Each key's standard deviation (its SI unit), ``None`` where the fit gives none.
    #[pyo3(get)]
    sigma: Py<PyAny>,
    /// Each key's 68 % interval ``(lo, hi)``, ``None`` without one.
    #[pyo3(get)]
    intervals: Py<PyAny>,
    /// The covariance in the keys' units (numpy array, NaN where a key has no sigma).
    #[pyo3(get)]
    covariance: Py<PyAny>,
    /// The columns of ``residuals.csv`` (dict of numpy arrays).
    #[pyo3(get)]
    residuals: Py<PyAny>,
    /// The fit as ``djkr.predict`` reads it (the texts of its files), or why it could not be.
    fitted: Result<djkr::fit::FitFolder, String>,
}

impl Fit {
    fn new(py: Python<'_>, r: api::FitResult) -> PyResult<Fit> {
        // The dict is fit.json's content: the report as JSON.
        let report = serde_json::to_value(&r.report)
            .map_err(|e| PyRuntimeError::new_err(format!("fit report: {e}")))?;
        let params = report["parameters"].as_array().cloned().unwrap_or_default();
        let keys = PyList::empty(py);
        let parameters = PyDict::new(py);
        let sigma = PyDict::new(py);
        let intervals = PyDict::new(py);
        for p in &params {
            let key = p["key"].as_str().unwrap_or_default();
            keys.append(key)?;
            parameters.set_item(key, p["value"].as_f64())?;
            sigma.set_item(key, p["sigma"].as_f64())?;
            let iv = p["interval"]
                .as_array()
                .and_then(|a| Some((a.first()?.as_f64()?, a.get(1)?.as_f64()?)));
            intervals.set_item(key, iv)?;
        }
        let k = params.len();
        let cov: Vec<f64> = (0..k)
            .flat_map(|a| {
                let row = report["covariance"][a].clone();
                (0..k).map(move |b| row[b].as_f64().unwrap_or(f64::NAN))
            })
            .collect();
        let covariance = PyArray1::from_vec(py, cov)
            .reshape([k, k])?
            .into_any()
            .unbind();
        let residuals = columns_to_py(py, r.residuals)?;
        Ok(Fit {
            report: json_to_py(py, &report)?,
            keys: keys.into_any().unbind(),
            parameters: parameters.into_any().unbind(),
            sigma: sigma.into_any().unbind(),
            intervals: intervals.into_any().unbind(),
            covariance,
            residuals: residuals.into_any().unbind(),
            fitted: r.fitted,
        })
    }
}

#[pymethods]
impl Fit {
    /// ``fit.json``'s entry ``key`` (``r["chi2"]``, ``r["parameters"]``, ``r["notes"]``).
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        report_item(&self.report, py, key)
    }

    /// ``fit.json``'s keys.
    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<bool> {
        self.report.bind(py).contains(key)
    }

    /// The residuals' table as a ``pandas.DataFrame`` (needs pandas).
    fn to_pandas(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        table_to_pandas(&self.residuals, py)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let r = self.report.bind(py);
        Ok(format!(
            "<djkr.Fit chi2={} converged={} parameters={}>",
            r.get_item("chi2")?.repr()?,
            r.get_item("converged")?.repr()?,
            self.parameters.bind(py).repr()?
        ))
    }
}

/// Predictions from a fit with their uncertainty, as ``djkr predict``.
///
/// For each point of the grid: the model at the fit's estimate, its standard deviation from the
/// fitted keys' covariance by linear propagation through the fit's own finite-difference
/// Jacobian, with an ensemble the standard error of the members' mean, the 68 % and 95 % bands,
/// and with ``samples`` the spread over parameter draws. The numbers are those of
/// ``djkr predict --json`` for the same fit and arguments, to the bit.
///
/// Parameters
/// ----------
/// fit : Fit, str or os.PathLike
///     What ``djkr.fit`` returned, or the folder a fit wrote (``djkr fit --out``, or
///     ``djkr.fit(out=...)``: ``fit.json``, ``fitted.toml``, ``residuals.csv``).
/// grid : dict, optional
///     The conditions to predict at, as ``djkr.sweep``'s ``grid``: each scenario key (not one
///     the fit estimated) with its values, a list (``["10um", "30um"]``, floats in SI) or a
///     range string (``"200:500:7"``); several keys make the Cartesian grid, the first
///     slowest. Default: the fit's data's own conditions.
/// samples : int, optional
///     Parameter draws (0, the default: none; else 2 to 100000) from the fit's distribution in
///     its coordinates (log space keys stay positive): the column ``sigma_samples``.
/// ensemble : int, optional
///     Members per point (>= 2): each value is the mean over that many base phases drawn from
///     ``seed`` (chaotic rigs), ``sigma_ensemble`` its standard error. Default: the fit's
///     ensemble, if it had one (so that at the data's conditions the values are the fit's).
/// seed : int, optional
///     Seed of the draws of ``samples`` and of the phases of ``ensemble`` (default 0).
/// observable : str, optional
///     The quantity to predict, as named in ``sweep.csv`` (``"pull_off_force"``,
///     ``"pull_off_amplification"``, ``"pull_off_time"``, ``"force_mean"``, ``"delta_mean"``,
///     ``"delta_amp"``). Default: the fit's.
/// jobs : int, optional
///     Runs at a time (default: one per core).
/// out : str or os.PathLike, optional
///     A folder for ``prediction.csv``, ``prediction.json``, ``prediction.png`` and
///     ``prediction.svg``, as ``djkr predict --out``.
/// force : bool, optional
///     Overwrite files of those names in ``out`` that djkr did not write (``--force``).
///
/// Returns
/// -------
/// Prediction
///     ``p["rows"]``, ``p["notes"]``, ... are the content of ``prediction.json``
///     (``p.report``); ``p.columns`` holds the columns of ``prediction.csv`` as numpy arrays
///     (``"base.amplitude [m]"``, ``"value [1]"``, ``"sigma_parameters [1]"``,
///     ``"sigma_ensemble [1]"``, ``"sigma [1]"``, ``"lo68 [1]"``, ``"hi68 [1]"``,
///     ``"lo95 [1]"``, ``"hi95 [1]"``, with samples ``"sigma_samples [1]"``; NaN where a
///     sigma is null; text conditions as lists); ``p.to_pandas()`` is that table.
///
/// Raises
/// ------
/// ScenarioError
///     A folder without a fit, a grid key the fit estimated, an observable djkr does not
///     produce, ``samples=1``, ``ensemble=1``, ``seed`` without ``samples`` or ``ensemble``.
/// KeyboardInterrupt
///     Ctrl-C: no new run starts, nothing is written.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
/// ...              free=["adhesion.v0", "adhesion.n"])
/// >>> p = djkr.predict(r, grid={"base.frequency": "250Hz",
/// ...                           "base.amplitude": "10um:60um:6"}, samples=100)
/// >>> p.to_pandas()[["base.amplitude [m]", "value [1]", "lo95 [1]", "hi95 [1]"]]
#[pyfunction]
#[pyo3(
    signature = (fit, grid = None, samples = None, ensemble = None, seed = None, observable = None, jobs = None, out = None, force = None),
    text_signature = "(fit, grid=None, samples=0, ensemble=None, seed=None, observable=None, jobs=None, out=None, force=False)"
)]
#[allow(clippy::too_many_arguments)]
fn predict(
    py: Python<'_>,
    fit: &Bound<'_, PyAny>,
    grid: Option<&Bound<'_, PyAny>>,
    samples: Option<&Bound<'_, PyAny>>,
    ensemble: Option<&Bound<'_, PyAny>>,
    seed: Option<&Bound<'_, PyAny>>,
    observable: Option<&Bound<'_, PyAny>>,
    jobs: Option<&Bound<'_, PyAny>>,
    out: Option<&Bound<'_, PyAny>>,
    force: Option<&Bound<'_, PyAny>>,
) -> PyResult<Prediction> {
    use djkr::fit::PredictRequest;
    let (folder, req, out) = guarded(|| {
        let folder = fit_folder(fit)?;
        let mut axes = Vec::new();
        let mut bytes = 0;
        if let Some(g) = dict_arg(grid, "grid")? {
            for (k, v) in g.iter() {
                let key = key_text(&k, "grid")?;
                let text = format!("{key}={}", spec_text(&v, &key, "grid")?);
                bytes += text.len();
                if bytes > text_limit() {
                    return Err(too_large("grid", None));
                }
                axes.push(Axis::parse(&text).map_err(|e| spec_err("grid", &e))?);
            }
        }
        let whole =
            |v, name| whole_arg(v, name, 0, usize::MAX as u64).map(|w| w.map(|w| w as usize));
        // The library refuses 1 and more than its bound, in its words.
        let samples = whole(samples, "samples")?.unwrap_or(0);
        let ensemble = whole(ensemble, "ensemble")?;
        let seed = whole_arg(seed, "seed", 0, u64::MAX)?;
        let observable = match observable {
            Some(o) if !o.is_none() => Some(str_arg(o, "observable")?),
            _ => None,
        };
        let jobs = whole(jobs, "jobs")?;
        if jobs == Some(0) {
            return Err(input_err(
                "jobs = 0: must be a whole number >= 1 (runs at a time)",
            ));
        }
        let out = path_arg(out, "out")?;
        let force = bool_arg(force, "force")?;
        if force && out.is_none() {
            return Err(input_err(
                "force=True has no effect without out= (it lets predict overwrite files in its \
                 folder): leave it out",
            ));
        }
        let req = PredictRequest {
            grid: axes,
            observable,
            ensemble: ensemble.map(|m| (m, seed.unwrap_or(0))),
            samples,
            seed,
            jobs: jobs.unwrap_or(0),
        };
        Ok((folder, req, out.map(|o| (o, force))))
    })?;
    let report = interruptible(py, move |stop| {
        api::predict(&folder, &req, out, Some(stop.flag()))
    })?;
    guarded(|| Prediction::new(py, report))
}

/// The result of ``djkr.predict``: the content of ``prediction.json`` and the columns of
/// ``prediction.csv``.
///
/// ``p["rows"]``, ``p["notes"]``, ``p["observable"]``, ... read ``prediction.json`` as a dict
/// does (``p.report`` is that dict). ``p.columns`` holds the columns of ``prediction.csv``
/// (numpy arrays named ``"name [unit]"``, SI; NaN where a sigma is null; text conditions as
/// lists): ``pandas.DataFrame(p.columns)`` is its table, as is ``p.to_pandas()``.
///
/// Examples
/// --------
/// >>> p = djkr.predict("out/fit", grid={"base.amplitude": ["10um", "30um"]})
/// >>> p.columns["value [1]"], p.columns["sigma [1]"], p["notes"]
#[pyclass(module = "djkr", frozen)]
struct Prediction {
    /// The content of ``prediction.json`` (a dict).
    #[pyo3(get)]
    report: Py<PyAny>,
    /// The columns of ``prediction.csv`` (dict of numpy arrays).
    #[pyo3(get)]
    columns: Py<PyAny>,
}

impl Prediction {
    fn new(py: Python<'_>, r: djkr::fit::PredictReport) -> PyResult<Prediction> {
        let (report, columns) =
            report_and_table(py, serde_json::to_value(&r), r.columns(), "prediction")?;
        Ok(Prediction { report, columns })
    }
}

#[pymethods]
impl Prediction {
    /// ``prediction.json``'s entry ``key`` (``p["rows"]``, ``p["notes"]``).
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        report_item(&self.report, py, key)
    }

    /// ``prediction.json``'s keys.
    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<bool> {
        self.report.bind(py).contains(key)
    }

    /// The table of ``prediction.csv`` as a ``pandas.DataFrame`` (needs pandas).
    fn to_pandas(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        table_to_pandas(&self.columns, py)
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.report.bind(py).get_item("rows")?.len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let r = self.report.bind(py);
        Ok(format!(
            "<djkr.Prediction observable={} points={} notes={}>",
            r.get_item("observable")?.repr()?,
            r.get_item("rows")?.len()?,
            r.get_item("notes")?.len()?
        ))
    }
}

// `djkr.Fit`, `djkr.Prediction` and `djkr.Design` are each a report (a dict, what the JSON file
// holds) and a table (a dict of columns); pyo3 classes cannot share a generic type, so they share
// these.

/// A report (as JSON) as the dict its JSON file holds, and `columns` as a dict of numpy arrays
/// (`what` names the report in an error).
fn report_and_table(
    py: Python<'_>,
    json: serde_json::Result<serde_json::Value>,
    columns: Vec<(String, api::Column)>,
    what: &str,
) -> PyResult<(Py<PyAny>, Py<PyAny>)> {
    let json = json.map_err(|e| PyRuntimeError::new_err(format!("{what} report: {e}")))?;
    Ok((
        json_to_py(py, &json)?,
        columns_to_py(py, columns)?.into_any().unbind(),
    ))
}

/// The report's entry `key`.
fn report_item(report: &Py<PyAny>, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    Ok(report.bind(py).get_item(key)?.unbind())
}

/// A table (a dict of columns) as a `pandas.DataFrame`.
fn table_to_pandas(table: &Py<PyAny>, py: Python<'_>) -> PyResult<Py<PyAny>> {
    let pd = py.import("pandas")?;
    Ok(pd.call_method1("DataFrame", (table.bind(py),))?.unbind())
}

/// The argument `fit` of `predict` and `design`: what `djkr.fit` returned, or a fit's folder.
fn fit_folder(fit: &Bound<'_, PyAny>) -> PyResult<djkr::fit::FitFolder> {
    if let Ok(f) = fit.cast::<Fit>() {
        f.get().fitted.clone().map_err(|m| {
            PyRuntimeError::new_err(format!("fit: this fit's result cannot be read back: {m}"))
        })
    } else if fit.is_instance_of::<PyString>() || fit.hasattr("__fspath__")? {
        let dir = path_arg(Some(fit), "fit")?.unwrap_or_default();
        djkr::fit::FitFolder::read(&dir).map_err(api_err)
    } else {
        Err(type_err(format!(
            "fit: expected what djkr.fit returned or a fit's folder (str or os.PathLike), got {}",
            type_name(fit)
        )))
    }
}

/// A table's columns by name: numbers and counts as numpy arrays (float64, int64), text as
/// lists.
fn columns_to_py<'py>(
    py: Python<'py>,
    columns: Vec<(String, api::Column)>,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    for (name, c) in columns {
        match c {
            api::Column::Num(v) => out.set_item(name, PyArray1::from_vec(py, v))?,
            api::Column::Whole(v) => {
                let v: Vec<i64> = v.into_iter().map(|x| x as i64).collect();
                out.set_item(name, PyArray1::from_vec(py, v))?
            }
            api::Column::Text(v) => out.set_item(name, v)?,
        }
    }
    Ok(out)
}

/// New measurements chosen from a fit, as ``djkr design``.
///
/// Of the candidates (a grid of conditions one could measure), the ``add`` new measurements
/// that, added to the fit's data, minimise the expected covariance of the fitted keys: the
/// model's sensitivities at the estimate (the fit's own finite-difference Jacobian) over the
/// expected noise of a measurement, a greedy choice then exchanges (Fedorov). Reported beside
/// them: the same number spread uniformly over the candidates. The numbers are those of
/// ``djkr design --json`` for the same fit and arguments, to the bit.
///
/// Parameters
/// ----------
/// fit : Fit, str or os.PathLike
///     What ``djkr.fit`` returned, or the folder a fit wrote (``djkr fit --out``, or
///     ``djkr.fit(out=...)``: ``fit.json``, ``fitted.toml``, ``residuals.csv``).
/// candidates : dict
///     The conditions one could measure, as ``djkr.sweep``'s ``grid``: each scenario key (not
///     one the fit estimated) with its values, a list (``["10um", "30um"]``, floats in SI) or a
///     range string (``"200:500:7"``, ``"30um/s:3mm/s:5log"``); several keys make the
///     Cartesian grid, the first slowest. 2 to 10000 candidates.
/// add : int
///     New measurements to choose (1 to 10000).
/// sigma : float or str, optional
///     The expected standard deviation of a new measurement: a number in the observable's SI
///     unit (or a string with a unit), or a percentage of the prediction (``"2%"``). Default:
///     the median relative sigma of the fit's data.
/// criterion : str, optional
///     What the design minimises: ``"D"`` (the default: the determinant of the keys'
///     covariance), ``"A"`` (the sum of their variances, in the fit coordinates) or a free key
///     of the fit (``"adhesion.n"``: its variance).
/// repeats : bool, optional
///     Whether a candidate may be chosen more than once (default True; ``False`` is
///     ``--no-repeats``).
/// jobs : int, optional
///     Runs at a time (default: one per core).
/// out : str or os.PathLike, optional
///     A folder for ``design.csv``, ``design.json``, ``design.png`` and ``design.svg``, as
///     ``djkr design --out``.
/// force : bool, optional
///     Overwrite files of those names in ``out`` that djkr did not write (``--force``).
///
/// Returns
/// -------
/// Design
///     ``d["chosen"]`` (a list of ``{"conditions": {key: value in SI}, "repeats": n, "row":
///     i}``), ``d["current_sigma"]``, ``d["expected_sigma"]``, ``d["uniform_sigma"]`` (each
///     ``{key: sigma}`` in the keys' SI units), ``d["criterion"]``, ``d["notes"]``, ... are the
///     content of ``design.json`` (``d.report``); ``d.columns`` holds the columns of
///     ``design.csv`` as numpy arrays (``"base.amplitude [m]"``, ``"value [1]"``,
///     ``"sigma_measurement [1]"``, ``"sigma_prediction [1]"``, ``"information [1]"``, and the
///     int64 ``"repeats [1]"``, ``"uniform_repeats [1]"``; text conditions as lists);
///     ``d.to_pandas()`` is that table.
///
/// Raises
/// ------
/// ScenarioError
///     A folder without a fit, a candidate key that is not a condition (unknown, or a key the
///     fit estimated), candidates that vary nothing (one point), ``add=0``, ``add`` above the
///     candidates with ``repeats=False``, a criterion that is not D, A or a free key, a sigma
///     that is not positive, no sigma where the fit's data carry none, a fit that gave a key no
///     sigma.
/// KeyboardInterrupt
///     Ctrl-C: no new run starts, nothing is written.
///
/// Examples
/// --------
/// >>> import djkr
/// >>> r = djkr.fit("measured.csv", "scenarios/paper-protocol-300hz.toml",
/// ...              free=["adhesion.v0", "adhesion.n"])
/// >>> d = djkr.design(r, {"base.amplitude": "0um:20um:5",
/// ...                     "stage[3].speed": "30um/s:3000um/s:5log"}, add=6)
/// >>> d["chosen"], d["expected_sigma"]["adhesion.n"], d["uniform_sigma"]["adhesion.n"]
#[pyfunction]
#[pyo3(
    signature = (fit, candidates, add, sigma = None, criterion = None, repeats = None, jobs = None, out = None, force = None),
    text_signature = "(fit, candidates, add, sigma=None, criterion='D', repeats=True, jobs=None, out=None, force=False)"
)]
#[allow(clippy::too_many_arguments)]
fn design(
    py: Python<'_>,
    fit: &Bound<'_, PyAny>,
    candidates: &Bound<'_, PyAny>,
    add: &Bound<'_, PyAny>,
    sigma: Option<&Bound<'_, PyAny>>,
    criterion: Option<&Bound<'_, PyAny>>,
    repeats: Option<&Bound<'_, PyAny>>,
    jobs: Option<&Bound<'_, PyAny>>,
    out: Option<&Bound<'_, PyAny>>,
    force: Option<&Bound<'_, PyAny>>,
) -> PyResult<Design> {
    use djkr::fit::{DesignRequest, Sigma, Target};
    let (folder, req, out) = guarded(|| {
        let folder = fit_folder(fit)?;
        let grid = dict_arg(Some(candidates), "candidates")?.filter(|d| !d.is_empty());
        let Some(grid) = grid else {
            return Err(input_err(
                "candidates: give the conditions one could measure as a dict of scenario keys \
                 and their values, e.g. {'base.frequency': '200:500:7', 'base.amplitude': \
                 '5um:100um:20'}",
            ));
        };
        let mut axes = Vec::new();
        let mut bytes = 0;
        for (k, v) in grid.iter() {
            let key = key_text(&k, "candidates")?;
            let text = format!("{key}={}", spec_text(&v, &key, "candidates")?);
            bytes += text.len();
            if bytes > text_limit() {
                return Err(too_large("candidates", None));
            }
            axes.push(Axis::parse(&text).map_err(|e| spec_err("candidates", &e))?);
        }
        // The library refuses 0 and more than its bound, in its words.
        let add = whole_arg(Some(add), "add", 0, usize::MAX as u64)?.unwrap_or(0) as usize;
        let mut req = DesignRequest::new(axes, add);
        if let Some(s) = sigma.filter(|s| !s.is_none()) {
            req.sigma = Some(Sigma::parse(&arg_text(s, "sigma")?, &folder).map_err(api_err)?);
        }
        if let Some(c) = criterion.filter(|c| !c.is_none()) {
            req.criterion = Target::parse(&str_arg(c, "criterion")?);
        }
        req.repeats = match repeats.filter(|r| !r.is_none()) {
            Some(r) => bool_arg(Some(r), "repeats")?,
            None => true,
        };
        let jobs = whole_arg(jobs, "jobs", 0, usize::MAX as u64)?;
        if jobs == Some(0) {
            return Err(input_err(
                "jobs = 0: must be a whole number >= 1 (runs at a time)",
            ));
        }
        req.jobs = jobs.unwrap_or(0) as usize;
        let out = path_arg(out, "out")?;
        let force = bool_arg(force, "force")?;
        if force && out.is_none() {
            return Err(input_err(
                "force=True has no effect without out= (it lets design overwrite files in its \
                 folder): leave it out",
            ));
        }
        Ok((folder, req, out.map(|o| (o, force))))
    })?;
    let report = interruptible(py, move |stop| {
        api::design(&folder, &req, out, Some(stop.flag()))
    })?;
    guarded(|| Design::new(py, report))
}

/// The result of ``djkr.design``: the content of ``design.json`` and the columns of
/// ``design.csv``.
///
/// ``d["chosen"]``, ``d["expected_sigma"]``, ``d["notes"]``, ... read ``design.json`` as a dict
/// does (``d.report`` is that dict). ``d.columns`` holds the columns of ``design.csv`` (numpy
/// arrays named ``"name [unit]"``, SI; ``repeats`` and ``uniform_repeats`` as int64; text
/// conditions as lists): ``pandas.DataFrame(d.columns)`` is its table, as is ``d.to_pandas()``.
///
/// Examples
/// --------
/// >>> d = djkr.design("out/fit", {"base.amplitude": "0um:20um:5"}, add=4)
/// >>> d["chosen"], d.columns["information [1]"], d["notes"]
#[pyclass(module = "djkr", frozen)]
struct Design {
    /// The content of ``design.json`` (a dict).
    #[pyo3(get)]
    report: Py<PyAny>,
    /// The columns of ``design.csv`` (dict of numpy arrays).
    #[pyo3(get)]
    columns: Py<PyAny>,
}

impl Design {
    fn new(py: Python<'_>, r: djkr::fit::DesignReport) -> PyResult<Design> {
        let (report, columns) =
            report_and_table(py, serde_json::to_value(&r), r.columns(), "design")?;
        Ok(Design { report, columns })
    }
}

#[pymethods]
impl Design {
    /// ``design.json``'s entry ``key`` (``d["chosen"]``, ``d["expected_sigma"]``).
    fn __getitem__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        report_item(&self.report, py, key)
    }

    /// ``design.json``'s keys.
    fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<bool> {
        self.report.bind(py).contains(key)
    }

    /// The table of ``design.csv`` as a ``pandas.DataFrame`` (needs pandas).
    fn to_pandas(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        table_to_pandas(&self.columns, py)
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let r = self.report.bind(py);
        Ok(format!(
            "<djkr.Design criterion={} add={} chosen={} candidates={}>",
            r.get_item("criterion")?.repr()?,
            r.get_item("add")?.repr()?,
            r.get_item("chosen")?.len()?,
            r.get_item("candidates")?.len()?
        ))
    }
}

/// A grid value of the argument `arg` (`grid`, `candidates`) as a sweep SPEC: a string as given
/// (`"10um:60um:6"`, `"10um,30um"`), a list of values joined by commas, a single value alone.
fn spec_text(v: &Bound<'_, PyAny>, key: &str, arg: &str) -> PyResult<String> {
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
                    "{arg}: {} value {} '{}' holds a comma, which separates values",
                    excerpt(key),
                    i + 1,
                    excerpt(&t)
                )));
            }
            // An array of a billion values is refused at its first megabyte.
            bytes += t.len() + 1;
            if bytes > text_limit() {
                return Err(too_large(arg, None));
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
    m.add("OutputFolderError", m.py().get_type::<OutputFolderError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Run>()?;
    m.add_class::<Fit>()?;
    m.add_class::<Prediction>()?;
    m.add_class::<Design>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(cycle, m)?)?;
    m.add_function(wrap_pyfunction!(pulloff, m)?)?;
    m.add_function(wrap_pyfunction!(validate, m)?)?;
    m.add_function(wrap_pyfunction!(resonance, m)?)?;
    m.add_function(wrap_pyfunction!(resonance_peak, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(points, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(predict, m)?)?;
    m.add_function(wrap_pyfunction!(design, m)?)?;
    Ok(())
}
