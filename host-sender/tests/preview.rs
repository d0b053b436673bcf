//! `gantry preview` and the VCD writer, end to end: SVG element counts, PNG size and content inside
//! the travel box, the bracket example through the interpreter and planner, VCD edge counts.

use gantry_machine::canon::{Action, ArcDir, Canon, Plane};
use gantry_machine::setup::Setup;
use gantry_machine::units::{Pos, NM_PER_MM};
use host_sender::preview::{self, adapt, raster, svg, Format, MoveKind, RenderOptions, View};
use host_sender::vcd::{read_vcd, write_vcd, write_vcd_with, VcdEvent, VcdOptions};

fn nm_of_mm(v: f64) -> i64 {
    (v * NM_PER_MM as f64).round() as i64
}

fn pos(x: f64, y: f64, z: f64) -> Pos {
    [nm_of_mm(x), nm_of_mm(y), nm_of_mm(z), 0, 0, 0]
}

/// A small known program: 2 rapids, 3 feeds, 2 arcs (one a full helical turn).
fn program() -> Vec<Canon> {
    let c = |line, action| Canon { line, action };
    vec![
        c(
            1,
            Action::Rapid {
                to: pos(0.0, 0.0, 5.0),
            },
        ),
        c(
            2,
            Action::Rapid {
                to: pos(10.0, 10.0, 5.0),
            },
        ),
        c(
            3,
            Action::Feed {
                to: pos(10.0, 10.0, -1.0),
                feed: nm_of_mm(300.0),
            },
        ),
        c(
            4,
            Action::Feed {
                to: pos(40.0, 10.0, -1.0),
                feed: nm_of_mm(1200.0),
            },
        ),
        c(
            5,
            Action::Arc {
                to: pos(50.0, 20.0, -1.0),
                center: [nm_of_mm(40.0), nm_of_mm(20.0), nm_of_mm(-1.0)],
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns: 1,
                feed: nm_of_mm(900.0),
            },
        ),
        c(
            6,
            Action::Feed {
                to: pos(50.0, 30.0, -1.0),
                feed: nm_of_mm(900.0),
            },
        ),
        c(
            7,
            Action::Arc {
                to: pos(50.0, 30.0, -2.0),
                center: [nm_of_mm(45.0), nm_of_mm(30.0), nm_of_mm(-1.0)],
                plane: Plane::XY,
                dir: ArcDir::Cw,
                turns: 1,
                feed: nm_of_mm(600.0),
            },
        ),
    ]
}

/// A setup whose travel box is just around the program, so it shows in every view.
fn tight_setup() -> Setup {
    let mut s = Setup::default();
    for (i, (lo, hi)) in [(-5.0, 60.0), (-5.0, 40.0), (-10.0, 10.0)]
        .iter()
        .enumerate()
    {
        s.axes[i].travel_min = nm_of_mm(*lo);
        s.axes[i].travel_max = nm_of_mm(*hi);
    }
    s
}

fn count(hay: &str, needle: &str) -> usize {
    hay.matches(needle).count()
}

#[test]
fn svg_has_one_path_per_move_per_view_and_dashed_rapids() {
    let job = adapt::from_canon(&program(), &tight_setup(), "known");
    assert_eq!(job.moves.len(), 7);
    let (text, layout) = svg::render_svg(&job, &RenderOptions::default());
    assert_eq!(layout.panels.len(), 4);
    // 7 moves × 4 views.
    assert_eq!(count(&text, r#"<path class="rapid""#), 2 * 4);
    assert_eq!(count(&text, r#"<path class="feed""#), 3 * 4);
    assert_eq!(count(&text, r#"<path class="arc""#), 2 * 4);
    // Every rapid and only rapids (plus the key's sample) carry the rapid dash pattern.
    let dashed = text
        .lines()
        .filter(|l| l.contains(r#"stroke-dasharray="5 3""#))
        .collect::<Vec<_>>();
    assert_eq!(dashed.len(), 2 * 4 + 1);
    assert!(dashed
        .iter()
        .take(8)
        .all(|l| l.contains(r#"class="rapid""#)));
    // Arcs are cubic Béziers: a quarter turn is 2 pieces, the full helix 8.
    let arc_lines: Vec<&str> = text
        .lines()
        .filter(|l| l.contains(r#"class="arc""#))
        .collect();
    assert_eq!(count(arc_lines[0], "C"), 2);
    assert_eq!(count(arc_lines[1], "C"), 8);
    // The travel box in every view, and the legend's figures.
    assert_eq!(count(&text, r#"<path class="travel""#), 4);
    assert!(text.contains("Total time"));
    assert!(text.contains("Programmed feed (mm/min)"));
    assert!(text.contains("✓ job inside machine travel"));
    // Parses as SVG.
    raster::rasterise(&text).unwrap();
}

#[test]
fn png_has_the_size_and_paths_inside_the_travel_box() {
    let setup = tight_setup();
    let job = adapt::from_canon(&program(), &setup, "known");
    let opts = RenderOptions {
        width: 1000,
        height: 700,
    };
    let png = preview::render(&job, Format::Png, &opts).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let pix = resvg::tiny_skia::Pixmap::decode_png(&png).unwrap();
    assert_eq!((pix.width(), pix.height()), (1000, 700));

    let (_, layout) = svg::render_svg(&job, &opts);
    let travel = preview::Box3::travel(&setup);
    for panel in &layout.panels {
        let b = panel.view.bounds(&travel);
        let (x0, y0) = panel.fit.px2(b[0], b[3]);
        let (x1, y1) = panel.fit.px2(b[2], b[1]);
        // Saturated pixels (the speed colours; grid, text and rapids are grey) inside the box.
        let mut coloured = 0;
        for y in (y0.max(0.0) as u32 + 2)..(y1.min(699.0) as u32 - 2) {
            for x in (x0.max(0.0) as u32 + 2)..(x1.min(999.0) as u32 - 2) {
                let p = pix.pixel(x, y).unwrap();
                let (r, g, b) = (p.red() as i32, p.green() as i32, p.blue() as i32);
                if r.max(g).max(b) - r.min(g).min(b) > 80 {
                    coloured += 1;
                }
            }
        }
        assert!(
            coloured > 100,
            "{:?}: {coloured} coloured pixels",
            panel.view
        );
    }
    // And the corners of the picture are background.
    let corner = pix.pixel(0, 0).unwrap();
    assert_eq!(
        (corner.red(), corner.green(), corner.blue()),
        (255, 255, 255)
    );
}

#[test]
fn text_renders_with_the_embedded_font() {
    // Only text: if no font were found the picture would stay white.
    let svg = r##"<svg xmlns="http://www.w3.org/2000/svg" width="200" height="40">
<rect width="200" height="40" fill="#fff"/>
<text x="5" y="30" font-size="24" font-family="DejaVu Sans, sans-serif">Gantry 123</text></svg>"##;
    let pix = raster::rasterise(svg).unwrap();
    let dark = pix.pixels().iter().filter(|p| p.red() < 128).count();
    assert!(dark > 200, "{dark} dark pixels");
}

#[test]
fn bracket_example_through_interpreter_and_planner() {
    let text = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/bracket.ngc"
    ))
    .unwrap();
    let p = preview::job_from_program(&text, false, &Setup::default(), "bracket.ngc").unwrap();
    assert!(p.error.is_none(), "{:?}", p.error);
    let job = &p.job;
    assert!(job.moves.len() > 30);
    assert!(job.moves.iter().any(|m| matches!(m.kind, MoveKind::Arc(_))));
    // Extents: the face pass goes from −4 to 64 / 44, the holes to −3.5, the end to Z10.
    let e = svg::Stats::of(job).extents;
    assert_eq!((e.min[0], e.max[0]), (-4.0, 64.0));
    assert_eq!((e.min[1], e.max[1]), (-4.0, 44.0));
    assert_eq!((e.min[2], e.max[2]), (-3.5, 10.0));
    let t = job.total_time_s.unwrap();
    assert!(t > 10.0 && t < 600.0, "total time {t}");
    let (svg_text, _) = svg::render_svg(job, &RenderOptions::default());
    assert_eq!(count(&svg_text, r#"<path class="rapid""#) % 4, 0);
    assert!(View::ALL.iter().all(|v| svg_text.contains(v.title())));
}

#[test]
fn run_writes_png_and_svg_files() {
    let dir = std::env::temp_dir().join(format!("gantry-preview-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let jsonl = dir.join("p.jsonl");
    std::fs::write(
        &jsonl,
        "{\"line\":1,\"op\":\"rapid\",\"to\":[0,0,5]}\n{\"line\":2,\"op\":\"feed\",\"to\":[20,0,5],\"feed\":500}\n",
    )
    .unwrap();
    for out in ["p.png", "p.svg"] {
        let out = dir.join(out);
        let code = preview::run(&jsonl, &out, &Setup::default(), &[0; 6]).unwrap();
        assert_eq!(code, std::process::ExitCode::SUCCESS);
        assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    }
    assert!(preview::run(&jsonl, &dir.join("p.jpg"), &Setup::default(), &[0; 6]).is_err());
    // A program error: the picture shows the program up to it, and the exit code says so.
    let bad = dir.join("bad.jsonl");
    std::fs::write(
        &bad,
        "{\"line\":1,\"op\":\"feed\",\"to\":[5,5,0],\"feed\":100}\n{\"line\":2,\"op\":\"error\",\"message\":\"E1: bad\"}\n",
    )
    .unwrap();
    let out = dir.join("bad.svg");
    let code = preview::run(&bad, &out, &Setup::default(), &[0; 6]).unwrap();
    assert_eq!(code, std::process::ExitCode::from(1));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(count(&text, r#"<path class="feed""#), 4);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vcd_rising_edges_equal_the_steps_fed_in() {
    // Three axes stepping at different rates, direction changes, enable on, an input toggling.
    let mut fed = [0u64; 3];
    let mut events = Vec::new();
    for k in 0..5000u64 {
        let t = 1_000 + k * 7_000;
        let mut step = 0u8;
        for (a, every) in [1u64, 3, 7].iter().enumerate() {
            if k % every == 0 {
                step |= 1 << a;
                fed[a] += 1;
            }
        }
        events.push(VcdEvent {
            time_ns: t,
            step,
            dir: if k < 2500 { 0b101 } else { 0b010 },
            enable: true,
            inputs: u32::from(k % 1000 < 10),
            outputs: u16::from(k % 2000 < 100) << 1,
            pwm: 0,
        });
    }
    let opts = VcdOptions {
        axes: 3,
        inputs: vec!["limit_x".into(), "hold".into()],
        outputs: 2,
        ..VcdOptions::default()
    };
    let mut out = Vec::new();
    let summary = write_vcd_with(&mut out, &opts, events.iter().copied()).unwrap();
    let text = String::from_utf8(out).unwrap();
    let trace = read_vcd(&text).unwrap();
    assert_eq!(trace.timescale, "1 ns");
    for (a, name) in ["x_step", "y_step", "z_step"].iter().enumerate() {
        assert_eq!(trace.rising[*name], fed[a], "{name}");
        assert_eq!(summary.steps[a], fed[a]);
    }
    assert_eq!(summary.merged, 0);
    assert_eq!(trace.rising["limit_x"], 5);
    assert_eq!(trace.rising["hold"], 0);
    assert_eq!(trace.rising["y_dir"], 1);
    assert_eq!(trace.rising["out0"], 0);
    // Output 1 is on for the first 100 of every 2000 events.
    assert_eq!(trace.rising["out1"], 3);

    // The plain entry point, 2 axes.
    let mut out = Vec::new();
    write_vcd(&mut out, 2, events.iter().copied()).unwrap();
    let trace = read_vcd(std::str::from_utf8(&out).unwrap()).unwrap();
    assert_eq!(
        trace.signals,
        ["x_step", "x_dir", "y_step", "y_dir", "enable"]
    );
    assert_eq!(trace.rising["y_step"], fed[1]);
}

#[test]
fn vcd_of_the_bracket_run_on_virtual_time() {
    use gantry_machine::motion::config::MotionConfig;
    use gantry_machine::motion::sim::{Sim, SimEvent};
    use gantry_machine::step::kernel::KERNEL_TIMER_HZ;
    use host_sender::vcd::{counts_to_ns, VcdWriter};

    let setup = Setup::default();
    let text = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../examples/bracket.ngc"
    ))
    .unwrap();
    let (canon, err) = preview::source::interpret(&text, &setup);
    assert!(err.is_none());
    let mut sim: Sim<128> = Sim::new(MotionConfig::from_setup(&setup));
    let mut fed = [0u64; 3];
    let mut buf = Vec::new();
    let mut w = VcdWriter::new(&mut buf, &VcdOptions::default()).unwrap();
    sim.run(canon, &mut |e| {
        if let SimEvent::Step(s) = e {
            for (a, n) in fed.iter_mut().enumerate() {
                *n += u64::from(s.step >> a & 1);
            }
            let e = VcdEvent {
                time_ns: counts_to_ns(s.time, KERNEL_TIMER_HZ),
                step: s.step,
                dir: s.dir,
                enable: true,
                inputs: 0,
                outputs: 0,
                pwm: 0,
            };
            w.event(e).unwrap();
        }
    })
    .unwrap();
    let summary = w.finish().unwrap();
    assert_eq!(summary.merged, 0);
    assert_eq!(summary.steps[..3], fed);
    assert!(fed.iter().all(|&n| n > 1000), "{fed:?}");
    let trace = read_vcd(std::str::from_utf8(&buf).unwrap()).unwrap();
    for (a, name) in ["x_step", "y_step", "z_step"].iter().enumerate() {
        assert_eq!(trace.rising[*name], fed[a], "{name}");
    }
    // The trace ends one pulse after the job's last step, on the planner's clock.
    let end_s = trace.end_time as f64 / 1e9;
    assert!(
        (end_s - sim.now as f64 / KERNEL_TIMER_HZ as f64).abs() < 0.01,
        "{end_s}"
    );
}

#[test]
fn drawn_arcs_follow_the_cores_arc_chords_in_every_plane() {
    use gantry_machine::motion::arc::ArcChords;
    use gantry_machine::motion::config::MotionConfig;
    use host_sender::preview::geom::arc_cubics;
    use host_sender::preview::ArcGeom;

    let cfg = MotionConfig::from_setup(&Setup::default());
    let to_mm = |p: &Pos| [0, 1, 2].map(|i| p[i] as f64 / NM_PER_MM as f64);
    // From (10, 0) around (0, 0) in plane coordinates, to 90° / 180° / back to the start,
    // optionally climbing 3 mm along the normal axis.
    for plane in [Plane::XY, Plane::ZX, Plane::YZ] {
        let (a, b, n) = match plane {
            Plane::XY => (0, 1, 2),
            Plane::ZX => (2, 0, 1),
            Plane::YZ => (1, 2, 0),
        };
        for dir in [ArcDir::Cw, ArcDir::Ccw] {
            for (end, turns, climb) in [
                ((0.0, 10.0), 1, 0.0),
                ((-10.0, 0.0), 1, 3.0),
                ((10.0, 0.0), 2, 3.0),
            ] {
                let mut from = [0i64; 6];
                let mut to = [0i64; 6];
                from[a] = nm_of_mm(10.0);
                to[a] = nm_of_mm(end.0);
                to[b] = nm_of_mm(end.1);
                to[n] = nm_of_mm(climb);
                let center = [0i64; 3];
                let mut chords = ArcChords::new(&cfg, &from, &to, &center, plane, dir, turns);
                let geom = ArcGeom {
                    center: [0.0; 3],
                    plane,
                    ccw: dir == ArcDir::Ccw,
                    turns,
                };
                let cubics = arc_cubics(to_mm(&from), to_mm(&to), &geom);
                let mut samples = Vec::new();
                for c in &cubics {
                    for k in 0..=400 {
                        let t = k as f64 / 400.0;
                        let s = 1.0 - t;
                        samples.push([0, 1, 2].map(|i| {
                            s * s * s * c[0][i]
                                + 3.0 * s * s * t * c[1][i]
                                + 3.0 * s * t * t * c[2][i]
                                + t * t * t * c[3][i]
                        }));
                    }
                }
                let mut worst = 0.0f64;
                while let Some(p) = chords.next_point() {
                    let p = to_mm(&p);
                    let d = samples
                        .iter()
                        .map(|q| {
                            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                                .sqrt()
                        })
                        .fold(f64::INFINITY, f64::min);
                    worst = worst.max(d);
                }
                assert!(
                    worst < 0.03,
                    "{plane:?} {dir:?} turns {turns} climb {climb}: {worst} mm off"
                );
            }
        }
    }
}

#[test]
fn empty_and_degenerate_jobs_still_render() {
    let setup = Setup::default();
    let empty = adapt::from_canon(&[], &setup, "empty");
    let png = preview::render(&empty, Format::Png, &RenderOptions::default()).unwrap();
    assert!(png.len() > 1000);
    // One move that goes nowhere, and a job with no travel box.
    let mut still = adapt::from_canon(
        &[Canon {
            line: 1,
            action: Action::Feed {
                to: [0; 6],
                feed: nm_of_mm(100.0),
            },
        }],
        &setup,
        "still",
    );
    still.travel = None;
    let (text, layout) = svg::render_svg(&still, &RenderOptions::default());
    assert!(!text.contains("NaN") && !text.contains("inf"));
    assert!(layout.panels.iter().all(|p| p.fit.scale.is_finite()));
    raster::rasterise(&text).unwrap();
}
