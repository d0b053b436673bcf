//! Hand-checked programs for the Fanuc coordinate transforms (docs/gcode-transforms.md): mirror
//! (G51.1), scaling (G51), rotation (G68) and polar coordinates (G16), most of them the
//! examples of the Hurco manual Gantry answers to (its §3.10, §3.18, §3.19, §3.23).
//!
//! Each `tests/golden/transforms/NN-name.ngc` runs through `host_sender::check::canon_output`
//! (what `gantry check --canon FILE` prints) and is compared with `NN-name.expected.jsonl`,
//! written by hand from the arithmetic in the program's comments (LinuxCNC has none of these
//! codes, so there is no oracle to record). Programs with `fanuc-int` in the name run with the
//! setup's Fanuc integer reading (`program.dwell_units = FanucIntegerMillis`). Compared:
//! `rapid`, `feed`, `arc` and `error` records, in order, a move to where the machine already is
//! dropped; coordinates within 1 nm of the hand values (printed to the nm); an error by its
//! `E<code>` only.
use std::fs;
use std::path::Path;

use gantry_machine::gcode::{DwellUnits, InterpConfig};
use serde_json::Value;

fn records(text: &str) -> Vec<Value> {
    let mut at = [0.0f64; 3];
    let mut out = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        let op = v["op"].as_str().unwrap_or("").to_string();
        if !matches!(op.as_str(), "rapid" | "feed" | "arc" | "error") {
            continue;
        }
        if let Some(to) = v["to"].as_array() {
            let to: Vec<f64> = to.iter().map(|x| x.as_f64().unwrap()).collect();
            let here = (0..3).all(|i| (to[i] - at[i]).abs() < 1e-9);
            at = [to[0], to[1], to[2]];
            if here && op != "arc" {
                continue;
            }
        }
        out.push(v);
    }
    out
}

fn same(expected: &Value, actual: &Value) -> bool {
    match (expected, actual) {
        (Value::Number(e), Value::Number(a)) => {
            (e.as_f64().unwrap() - a.as_f64().unwrap()).abs() <= 1.000_001e-6
        }
        (Value::Array(e), Value::Array(a)) => {
            e.len() == a.len() && e.iter().zip(a).all(|(e, a)| same(e, a))
        }
        (Value::Object(e), Value::Object(a)) => {
            e.len() == a.len()
                && e.iter().all(|(k, ev)| match (k.as_str(), a.get(k)) {
                    ("message", Some(Value::String(m))) => m.starts_with(ev.as_str().unwrap()),
                    (_, Some(av)) => same(ev, av),
                    (_, None) => false,
                })
        }
        (e, a) => e == a,
    }
}

#[test]
fn transforms_match_the_hand_checked_motions() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("golden/transforms");
    let mut names: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "ngc"))
        .collect();
    names.sort();
    assert!(names.len() >= 7, "programs in {}", dir.display());
    let mut failures = Vec::new();
    for ngc in &names {
        let name = ngc.file_stem().unwrap().to_string_lossy().to_string();
        let mut config = InterpConfig::default();
        if name.contains("fanuc-int") {
            config.dwell_units = DwellUnits::FanucIntegerMillis;
        }
        let program = fs::read(ngc).unwrap();
        let (out, _) = host_sender::check::canon_output(&program, &config);
        let expected = fs::read_to_string(dir.join(format!("{name}.expected.jsonl"))).unwrap();
        let (e, a) = (records(&expected), records(&out));
        let first_bad = (0..e.len().max(a.len())).find(|&i| match (e.get(i), a.get(i)) {
            (Some(e), Some(a)) => !same(e, a),
            _ => true,
        });
        if let Some(i) = first_bad {
            failures.push(format!(
                "{name}: record {i}: expected {:?}, got {:?}",
                e.get(i).map(|v| v.to_string()),
                a.get(i).map(|v| v.to_string())
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The motion records (`rapid`, `feed`, `arc`) of `gantry check --canon` output, as (line, op).
fn motion_lines(canon: &str) -> Vec<(u64, String)> {
    canon
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter(|v| matches!(v["op"].as_str(), Some("rapid" | "feed" | "arc")))
        .map(|v| {
            (
                v["line"].as_u64().unwrap(),
                v["op"].as_str().unwrap().to_owned(),
            )
        })
        .collect()
}

/// A `G0` or `G1` block with no axis words under a mirror, scaling or rotation makes no motion
/// (Fanuc, Hurco, LinuxCNC): no record, and the next move starts from where the tool stands.
/// Checked through the binary (`gantry check --canon`) as well as in-process.
#[test]
fn an_axis_less_move_under_a_transform_makes_no_motion() {
    // The transform, and where `G0 X40` (line 7) goes under it from X30 Y20.
    let cases = [
        ("G51.1 X15.", [-10.0, 20.0]),
        ("G51 X0 Y0 P2.", [80.0, 40.0]),
        ("G68 X0 Y0 R90.", [-20.0, 40.0]),
    ];
    let dir = std::env::temp_dir().join(format!("gantry-axisless-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    for (xf, x40) in cases {
        let program = format!("G21 G90 G54\nG0 X30 Y20 Z-1\n{xf}\nG0\nG1 F100\nF200\nG0 X40\nM2\n");
        let (canon, _) = host_sender::check::canon_output(program.as_bytes(), &Default::default());
        let path = dir.join("axisless.ngc");
        fs::write(&path, &program).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_gantry-under-test"))
            .args(["check", "--canon", path.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(out.status.success(), "{xf}: {out:?}");
        let binary = String::from_utf8(out.stdout).unwrap();
        assert_eq!(
            binary, canon,
            "{xf}: the binary prints what canon_output gives"
        );
        assert_eq!(
            motion_lines(&canon),
            [(2, "rapid".to_owned()), (7, "rapid".to_owned())],
            "{xf}: {canon}"
        );
        let last: Value = canon
            .lines()
            .map(|l| serde_json::from_str::<Value>(l).unwrap())
            .rfind(|v| v["op"] == "rapid")
            .unwrap();
        let to: Vec<f64> = last["to"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        // The scaling centre's Z is the current program point's: Z stays at -1 under G51 too.
        assert_eq!(to, [x40[0], x40[1], -1.0], "{xf}: {canon}");
    }
    let _ = fs::remove_dir_all(&dir);
}
