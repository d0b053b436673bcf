//! G5/G5.1 splines against LinuxCNC's linearisation (tests/golden/g5/README.md).
//!
//! rs274 prints a spline only as `NURBS_FEED(n, ...)`: the arcs LinuxCNC cuts come from its canon
//! layer, written again in double precision in scripts/g5_reference.py, which made
//! `NN-name.expected.jsonl`. The moves after each spline in the programs are rs274's own
//! (`NN-name.rs274.txt`), so the spline's end point is checked against rs274 as well.
//!
//! Compared: every record's op, line and direction; end points, and the middle point of every
//! arc, within 0.00015 mm (the rs274 goldens' tolerance). Arc centres are not compared as
//! numbers: a piece near an inflection is an arc of a radius far above its chord, whose centre
//! moves by R²/L per unit of tangent angle, so the reference's and Gantry's centres may be
//! 0.1 mm apart while the paths agree to the nanometre (the middle points check the path).
use std::fs;
use std::path::PathBuf;

use serde_json::Value;

const TOL_MM: f64 = 0.00015;

fn xy(v: &Value, key: &str) -> (f64, f64) {
    let p = v[key].as_array().expect("point");
    (p[0].as_f64().unwrap(), p[1].as_f64().unwrap())
}

/// The middle of the arc `rec` from `from`.
fn arc_middle(from: (f64, f64), rec: &Value) -> (f64, f64) {
    let (cx, cy) = xy(rec, "center");
    let to = xy(rec, "to");
    let a0 = (from.1 - cy).atan2(from.0 - cx);
    let mut a1 = (to.1 - cy).atan2(to.0 - cx);
    let tau = std::f64::consts::TAU;
    if rec["dir"] == "ccw" {
        while a1 <= a0 {
            a1 += tau;
        }
    } else {
        while a1 >= a0 {
            a1 -= tau;
        }
    }
    let r = (from.0 - cx).hypot(from.1 - cy);
    let m = (a0 + a1) / 2.0;
    (cx + r * m.cos(), cy + r * m.sin())
}

fn records(text: &str) -> Vec<Value> {
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| serde_json::from_str(l).expect("json line"))
        .filter(|v: &Value| v["op"] != "golden")
        .collect()
}

#[test]
fn splines_match_linuxcnc_linearisation() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("golden/g5");
    let mut programs: Vec<PathBuf> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ngc"))
        .collect();
    programs.sort();
    assert!(!programs.is_empty());
    for ngc in programs {
        let name = ngc.file_stem().unwrap().to_string_lossy().to_string();
        let program = fs::read_to_string(&ngc).unwrap();
        let expected =
            records(&fs::read_to_string(dir.join(format!("{name}.expected.jsonl"))).unwrap());
        let actual = records(&host_sender::check::canon_jsonl(&program));
        assert_eq!(expected.len(), actual.len(), "{name}: record count");
        let arcs = expected.iter().filter(|r| r["op"] == "arc").count();
        assert!(arcs > 20, "{name}: the splines became arcs ({arcs})");
        let (mut from_e, mut from_a) = ((0.0, 0.0), (0.0, 0.0));
        for (i, (e, a)) in expected.iter().zip(&actual).enumerate() {
            for key in ["op", "line", "dir"] {
                assert_eq!(e[key], a[key], "{name}: record {i} {key}: {e} / {a}");
            }
            if e.get("to").is_none() {
                continue;
            }
            let (te, ta) = (xy(e, "to"), xy(a, "to"));
            assert!(
                (te.0 - ta.0).abs() <= TOL_MM && (te.1 - ta.1).abs() <= TOL_MM,
                "{name}: record {i} end: {e} / {a}"
            );
            if e["op"] == "arc" {
                let (me, ma) = (arc_middle(from_e, e), arc_middle(from_a, a));
                assert!(
                    (me.0 - ma.0).abs() <= TOL_MM && (me.1 - ma.1).abs() <= TOL_MM,
                    "{name}: record {i} middle {me:?} / {ma:?}: {e} / {a}"
                );
            }
            (from_e, from_a) = (te, ta);
        }
    }
}
