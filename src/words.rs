//! How a front end words what its user gave it ([`Words`]), and where a scenario came from
//! ([`Source`]): the vocabulary the library's errors are written in (an input named inside a
//! message as `«name»`, an override as `«set:KEY=VALUE»`, a sweep's axis as `«axis:KEY=SPEC»`),
//! below every module that writes one. [`crate::error`] re-exports it.

use std::fmt;

/// How a front end names what its user gave it.
pub trait Words {
    /// `name`, an input of a request (its field name: `a_amp`, `freq`, `out`), as this front end
    /// spells it: `--a-amp` on the command line, `a_amp` in Python.
    fn input(&self, name: &str) -> String;
    /// Overrides of scenario keys (`KEY=VALUE` each, in order) as this front end takes them:
    /// `--set K=V --set K2=V2` on the command line, `set={'K': V, 'K2': V2}` in Python.
    fn overrides(&self, items: &[String]) -> String;
    /// An override that did not parse or names no key (`KEY=VALUE`, or whatever was given), as
    /// this front end shows it: `--set K=V` on the command line, `set={'K': ...}` in Python (its
    /// value plays no part).
    fn malformed_override(&self, set: &str) -> String;
    /// An axis of a sweep (`KEY=SPEC`: a list or a range of values) that did not parse: `--set
    /// K=SPEC` on the command line, `grid={'K': ...}` in Python.
    fn axis(&self, spec: &str) -> String;
    /// An input with its value, where a message names both: `--ensemble 5`, `ensemble = 5`.
    fn input_value(&self, name: &str, value: &str) -> String;
}

/// The library's own words, for Rust callers: inputs by their field names, overrides as
/// `set K=V, K2=V2`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Plain;

impl Words for Plain {
    fn input(&self, name: &str) -> String {
        name.to_string()
    }
    fn overrides(&self, items: &[String]) -> String {
        format!("set {}", items.join(", "))
    }
    fn malformed_override(&self, set: &str) -> String {
        format!("set {set}")
    }
    fn axis(&self, spec: &str) -> String {
        format!("axis {spec}")
    }
    fn input_value(&self, name: &str, value: &str) -> String {
        format!("{name} = {value}")
    }
}

/// `text` with every `«name»` (an input named inside a message), `«name=value»` (an input with
/// its value), `«set:KEY=VALUE»` (an override) and `«axis:KEY=SPEC»` (a sweep's axis) in the
/// words of `w`.
pub fn render(text: &str, w: &dyn Words) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find('«') {
        let after = &rest[i + '«'.len_utf8()..];
        match after.find('»') {
            Some(j) => {
                out.push_str(&rest[..i]);
                let inner = &after[..j];
                if let Some(item) = inner.strip_prefix("set:") {
                    out.push_str(&w.overrides(&[item.to_string()]));
                } else if let Some(spec) = inner.strip_prefix("axis:") {
                    out.push_str(&w.axis(spec));
                } else if let Some((name, value)) = inner.split_once('=') {
                    out.push_str(&w.input_value(name, value));
                } else {
                    out.push_str(&w.input(inner));
                }
                rest = &after[j + '»'.len_utf8()..];
            }
            None => break,
        }
    }
    out.push_str(rest);
    out
}

/// `«name»`: the input `name` inside a message, for [`render`] to word.
pub fn input(name: &str) -> String {
    format!("«{name}»")
}

/// `«name=value»`: the input `name` with its value inside a message (`--ensemble 5`,
/// `ensemble = 5`), for [`render`] to word.
pub fn input_value(name: &str, value: &str) -> String {
    format!("«{name}={value}»")
}

/// `«axis:KEY=SPEC»`: a sweep's axis inside a message, for [`render`] to word.
pub fn axis_item(spec: &str) -> String {
    format!("«axis:{spec}»")
}

/// `«set:KEY=VALUE»`: an override inside a message, for [`render`] to word.
pub fn set_item(item: &str) -> String {
    format!("«set:{item}»")
}

/// Where a scenario came from: its file (a path, `<string>`, `<dict>`) and the overrides applied
/// to the file's values (`KEY=VALUE`, in order).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Source {
    /// The file's name as messages give it (usually its path).
    pub file: String,
    /// The overrides, `KEY=VALUE` each.
    pub set: Box<[String]>,
}

impl Source {
    /// A file used as written.
    pub fn file(file: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            set: Box::default(),
        }
    }

    /// The file and its overrides in the words of `w`: `FILE --set K=V`.
    pub fn words(&self, w: &dyn Words) -> String {
        if self.set.is_empty() {
            self.file.clone()
        } else {
            format!("{} {}", self.file, w.overrides(&self.set))
        }
    }
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.words(&Plain))
    }
}

/// The command line's words, for the library's own tests of its messages (the command line's
/// [`Words`] live in the binary).
#[cfg(test)]
pub(crate) struct TestFlags;

#[cfg(test)]
impl Words for TestFlags {
    fn input(&self, name: &str) -> String {
        if name.contains('.') || name.starts_with('-') {
            return name.to_string();
        }
        format!("--{}", name.replace('_', "-"))
    }
    fn overrides(&self, items: &[String]) -> String {
        items
            .iter()
            .map(|i| format!("--set {i}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
    fn malformed_override(&self, set: &str) -> String {
        format!("--set {set}")
    }
    fn axis(&self, spec: &str) -> String {
        format!("--set {spec}")
    }
    fn input_value(&self, name: &str, value: &str) -> String {
        format!("{} {value}", self.input(name))
    }
}
