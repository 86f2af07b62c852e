//! TOML parsing and validation of scenario files (in progress).
