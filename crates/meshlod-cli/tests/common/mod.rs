//! Helpers shared by the tests that run the real `meshlod` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `meshlod` with `args`.
pub fn meshlod(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshlod"))
        .args(args)
        .output()
        .expect("run meshlod")
}

/// The JSON object on the last line of a successful run's stdout (panics, with
/// stderr, when the run failed).
pub fn ok(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "meshlod failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    serde_json::from_str(stdout.lines().last().expect("a line")).expect("JSON")
}

/// `tests/data` at the repository root.
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data")
}
