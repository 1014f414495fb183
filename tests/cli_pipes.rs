//! A reader that closes the pipe early (`gearvib ... | head -c 10`) is not an error: exit 0, nothing on
//! stderr, no panic.

use std::io::Read;
use std::process::{Command, Stdio};

fn closed_early(args: &[&str], keep: usize) -> (i32, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_gearvib"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    let mut out = child.stdout.take().expect("piped");
    let mut first = vec![0u8; keep];
    out.read_exact(&mut first).expect("some output");
    drop(out); // like `head -c 10`: the read end closes while gearvib still writes
    let status = child.wait().expect("exits");
    let mut err = String::new();
    child.stderr.take().expect("piped").read_to_string(&mut err).expect("stderr");
    (status.code().unwrap_or(-1), err)
}

#[test]
fn closed_stdout_ends_quietly() {
    // the sweep's JSON line (~300 kB) is larger than a pipe's buffer (64 kB): gearvib is certainly still
    // writing when the pipe closes
    for args in [
        &["simulate", "data/scenes/paper-gear-fig8a.json"][..],
        &["simulate", "data/scenes/paper-gear-fig8a.json", "--json"][..],
        &[
            "sweep",
            "data/scenes/paper-gear-fig8a.json",
            "--param",
            "speed",
            "--from",
            "1000",
            "--to",
            "2000",
            "--steps",
            "400",
        ][..],
    ] {
        let (code, err) = closed_early(args, 10);
        assert_eq!(code, 0, "{args:?}: {err}");
        // nothing on stderr but, on a slow or busy machine, a sweep's run-time estimate (said when the
        // estimate exceeds 2 s, which depends on the machine)
        assert!(err.lines().all(|l| l.contains("estimated run time")), "{args:?}: stderr {err:?}");
    }
}
