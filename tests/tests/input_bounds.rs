//! No input makes `gantry` read without bound. A program with an endless line
//! and `/dev/zero` as a program or a setup file are refused at once with a clear error; an error
//! quotes at most a line's first 100 characters.

mod serial_support;

use serial_support::*;
use std::time::Duration;

const T: Duration = Duration::from_secs(20);

#[test]
fn endless_lines_and_dev_zero_are_refused_at_once() {
    let dir = Dir::new("input-bounds");
    // 8 MiB without a line end.
    let endless = dir.0.join("endless.ngc");
    std::fs::write(&endless, vec![b'X'; 8 << 20]).unwrap();
    for args in [
        vec!["check", endless.to_str().unwrap()],
        vec!["simulate", endless.to_str().unwrap()],
        vec!["check", "/dev/zero"],
        vec!["simulate", "/dev/zero"],
        vec!["preview", "/dev/zero", "-o", "/tmp/never.png"],
        vec!["stream", "/dev/zero"],
    ] {
        let out = gantry(&args, T);
        assert_eq!(out.code, Some(2), "{args:?}: {out:?}");
        assert!(
            out.stderr.contains(":1: line longer than 65536 characters"),
            "{args:?}: {out:?}"
        );
        assert!(
            out.stdout.len() + out.stderr.len() < 1000,
            "{args:?} echoed it"
        );
        assert!(out.took < Duration::from_secs(5), "{args:?}: {out:?}");
    }
    let out = gantry(&["setup", "check", "/dev/zero"], T);
    assert_eq!(out.code, Some(2), "{out:?}");
    assert!(out.stderr.contains("not a setup file"), "{out:?}");
}

#[test]
fn an_error_quotes_at_most_the_first_100_characters_of_its_line() {
    let dir = Dir::new("quote-bound");
    let long = format!("G1 X1 Q5 ({})\n", "c".repeat(5000));
    let file = dir.file("long.ngc", &format!("G21\n{long}"));
    let out = gantry(&["check", file.to_str().unwrap()], T);
    assert_eq!(out.code, Some(1), "{out:?}");
    let quoted = out
        .stdout
        .lines()
        .find(|l| l.starts_with("    G1 X1 Q5"))
        .expect("the line is quoted");
    assert_eq!(quoted.chars().count(), 4 + 100 + 2, "{quoted}");
    assert!(quoted.ends_with(" …"));
    assert!(out.stdout.len() < 2000, "{out:?}");
}

/// `status` and `setup pull` with no board refuse (a fresh emulated board's
/// state says nothing of the machine) unless `--emulated` asks for it.
#[test]
fn status_and_setup_pull_without_a_board_refuse_unless_emulated() {
    for args in [vec!["status"], vec!["setup", "pull"]] {
        let out = gantry(&args, T);
        assert_eq!(out.code, Some(2), "{args:?}: {out:?}");
        assert!(out.stderr.contains("add --emulated"), "{args:?}: {out:?}");
        let mut emulated = vec!["--emulated"];
        emulated.extend(args.iter().copied());
        let out = gantry(&emulated, T);
        assert_eq!(out.code, Some(0), "{emulated:?}: {out:?}");
    }
}
