//! The machine setup file: a commented TOML in everyday units (mm, mm/min, mm/s²), read into the
//! core's exact [`Setup`] and written back out. Every validation error names the key and the range.
//!
//! Reader and writer are two walks over the settings table (machine/src/setup/table.rs): each row
//! gives its key, section and unit, the core's range check and its setter (reading) or getter
//! (writing) and the comment written after its value. The row's unit says how its integer
//! reads: scaled decimals, whole numbers, booleans, choices by name, or names (axis letters and
//! input names as masks and pairs, an input, an output). Only the text-valued rows (the axes in
//! use, M codes, positions, lists, startup lines) have codecs of their own, in `codec`.
//!
//! One job a module: `read` walks the table reading, `write` walks it writing, `codec` holds
//! the text-valued rows' codecs and the value helpers both walks use, `layout` where
//! each row sits in the file, `check` finds every error of a file (`gantry setup check`) and
//! `keep` what a push leaves of the board's own (offsets, G28/G30, tools).
//!
//! Decimal values are converted to integer nanometres with rounding to the nearest nm; the file is
//! the only place where a float ever touches a setting.

mod check;
mod codec;
mod keep;
mod layout;
mod read;
mod write;

pub use write::to_toml;

use read::read;

use anyhow::Context;
use gantry_machine::setup::Setup;
use std::path::Path;
use toml::Table;

#[cfg(test)]
use gantry_machine::{
    setup::table::{Unit, ROWS},
    setup::ListCommand,
    units::NM_PER_MM,
};

/// The largest setup file read, bytes (a full setup with every tool and list is about 10 KiB).
pub(crate) const SETUP_FILE_LIMIT: u64 = 1024 * 1024;

/// The setup file's reader (its writer is [`to_toml`]).
pub struct SetupFile;

impl SetupFile {
    /// Reads and validates a setup file.
    pub fn load(path: &Path) -> anyhow::Result<Setup> {
        let text = Self::read_bounded(path)?;
        Self::parse(&text).with_context(|| format!("in setup file {}", path.display()))
    }

    /// [`SetupFile::load`] for a push to a board whose setup is `stored`, and what of it was
    /// kept that holds anything (for a message: "work offsets G54 G55", "G28 position", "tool
    /// table (2 tools)"): the work offsets, the G28/G30 positions and the tool table are the
    /// board's (the operator set them with G10, G28.1, G30.1 and the board keeps them in flash)
    /// unless the file names them, so a push never clears them by accident (docs/controller.md
    /// "Work offsets"). `gantry emulate --setup F --state S` starts from it with S's setup.
    pub(crate) fn load_keeping(
        path: &Path,
        stored: &Setup,
    ) -> anyhow::Result<(Setup, Vec<String>)> {
        let text = Self::read_bounded(path)?;
        Self::parse_keeping(&text, stored)
            .with_context(|| format!("in setup file {}", path.display()))
    }

    /// [`SetupFile::load_keeping`] on setup text without the list (the console's editor; the
    /// one push path, `crate::session::Session::push_setup_text`).
    pub(crate) fn parse_for_push(text: &str, board: &Setup) -> anyhow::Result<Setup> {
        Self::parse_keeping(text, board).map(|(s, _)| s)
    }

    /// [`SetupFile::load_keeping`] on setup text. An empty setup (no setting at all: an empty
    /// editor, only comments) is refused: pushed, it would set every default (travel, steps per
    /// mm, switch polarity, homing) on the machine.
    pub(crate) fn parse_keeping(
        text: &str,
        stored: &Setup,
    ) -> anyhow::Result<(Setup, Vec<String>)> {
        let root: Table = toml::from_str(text)?;
        anyhow::ensure!(
            !root.is_empty(),
            "an empty setup (no setting in it): nothing was pushed (`gantry setup pull` or the \
             console's \"Show the board's\" gives the board's setup to edit)"
        );
        let s = read(&root)?;
        Ok(keep::boards_own(&root, s, stored))
    }

    /// The file's text, refused beyond [`SETUP_FILE_LIMIT`].
    pub fn read_bounded(path: &Path) -> anyhow::Result<String> {
        use std::io::Read;
        let mut text = String::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(SETUP_FILE_LIMIT + 1).read_to_string(&mut text))
            .with_context(|| format!("cannot read setup file {}", path.display()))?;
        anyhow::ensure!(
            text.len() as u64 <= SETUP_FILE_LIMIT,
            "setup file {}: longer than {} KiB, not a setup file (a full setup is about 10 KiB)",
            path.display(),
            SETUP_FILE_LIMIT / 1024
        );
        Ok(text)
    }

    /// Parses and validates setup text: every value over the defaults.
    pub fn parse(text: &str) -> anyhow::Result<Setup> {
        read(&toml::from_str(text)?)
    }

    /// Every error of setup text (`gantry setup check`), each with its line (0: unknown) and a
    /// message naming its key: each setting is read on its own (with `axes`, which decides what
    /// the others may name), so one bad key does not hide the next; the rules between settings
    /// are checked once every setting is valid on its own. Empty: the text is valid.
    pub fn check_all(text: &str) -> Vec<(u32, String)> {
        check::every_error(text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pair_takes_exactly_two_values() {
        for text in [
            "[axis.X]\nsteps_per = [3200, 5.0, 7]\n",
            "[axis.X]\ntravel = [-300.0, 300.0, 5.0]\n",
            "[axis.X]\ntravel = [-300.0]\n",
            "[operator]\nfro_range = [10, 200, 300]\n",
            "[jog]\npair0 = [\"Y\", \"X\", \"Z\"]\n",
        ] {
            let e = format!("{:#}", SetupFile::parse(text).unwrap_err());
            assert!(
                e.contains("expected a list of exactly two values"),
                "{text}: {e}"
            );
        }
        let s = SetupFile::parse("[axis.X]\ntravel = [-250.0, 250.0]\n").unwrap();
        assert_eq!(
            (s.axes[0].travel_min, s.axes[0].travel_max),
            (-250 * NM_PER_MM, 250 * NM_PER_MM)
        );
    }

    #[test]
    fn defaults_round_trip_through_the_file() {
        let s = Setup::default();
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
    }

    #[test]
    fn values_convert_exactly_to_nanometres() {
        let s = SetupFile::parse(
            "axes = [\"X\", \"Y\", \"Z\", \"A\"]\n[axis.a]\nsteps_per = [4000, 360.0]\n[path]\nchord_tolerance = 0.002\n[[tool]]\nnumber = 3\nlength = 25.4001\n",
        )
        .unwrap();
        assert_eq!(s.axis_count, 4);
        assert_eq!((s.axes[3].steps, s.axes[3].units_nm), (4000, 360_000_000));
        assert_eq!(s.path.chord_tolerance, 2_000);
        assert_eq!(s.program.tools[0].length, 25_400_100);
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
    }

    #[test]
    fn the_tool_change_position_reads_writes_and_stays_inside_the_travel() {
        let s = SetupFile::parse(
            "[axis.Z]\ntravel = [-80.0, 20.0]\n[program]\ntool_change_position = { x = -12.5, Z = 20.0 }\n",
        )
        .unwrap();
        let place = s.program.tool_change_position;
        assert_eq!(place.axes, 0b101);
        assert_eq!(place.at, [-12_500_000, 0, 20_000_000, 0, 0, 0]);
        let text = to_toml(&s);
        assert!(
            text.contains("tool_change_position = { X = -12.5, Z = 20.0 }"),
            "{text}"
        );
        assert_eq!(SetupFile::parse(&text).unwrap(), s);
        let e = SetupFile::parse(
            "[axis.Z]\ntravel = [-80.0, 20.0]\n[program]\ntool_change_position = { Z = 25.0 }\n",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.tool_change_position.Z = 25: outside the Z travel [-80.0, 20.0] (soft limits)"
        );
        let e = SetupFile::parse("[program]\ntool_change_position = { A = 1.0 }\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.tool_change_position.A: not an axis in use (axes in use: ['X', 'Y', 'Z'])"
        );
    }

    #[test]
    fn errors_name_the_key_and_the_range() {
        let e = SetupFile::parse("[axis.X]\nmax_rate = -5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.X.max_rate = -5: must be between 1 and 200000"
        );
        let e = SetupFile::parse("[axis.A]\nmax_rate = 5\n").unwrap_err();
        assert!(
            e.to_string().starts_with("axis.A: not an axis in use"),
            "{e}"
        );
        let e = SetupFile::parse("[path]\nwobble = 1\n").unwrap_err();
        assert!(e.to_string().contains("unknown field `wobble`"), "{e}");
        let e = SetupFile::parse("[operator]\nfro_range = [150, 100]\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "operator.fro_range[0] = 150: must not exceed operator.fro_range[1] (100 %)"
        );
        // Rules between settings come from the core's validation (machine/src/setup/validate.rs).
        let e = SetupFile::parse(
            "[axis.Y]
max_rate = 10
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.Y.start_speed = 60: must not exceed axis.Y.max_rate (10)"
        );
        let e = SetupFile::parse(
            "[axis.Z]
travel = [5.0, -5.0]
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.Z.travel[0] = 5: must not exceed axis.Z.travel[1] (-5)"
        );
        let e = SetupFile::parse(
            "[jog]
analog_deadband = 2048
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "jog.analog_deadband = 2048: must be below half of inputs.adc_max (4095)"
        );
        let e = SetupFile::parse(
            "[program]
dialect = \"fanuc\"
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "program.dialect = \"fanuc\": must be \"ngc\" or \"gixa\""
        );
        let e = SetupFile::parse(
            "[[tool]]
number = 1
diameter = -1
",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "tool[0].diameter = -1: must be between 0 and 1000"
        );
        let e = SetupFile::parse("[program]\nuser_mcodes = [3]\n").unwrap_err();
        assert!(e.to_string().contains("M3 is reserved"), "{e}");
        let e = SetupFile::parse("[inputs]\ndebounce_ms = 0\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "inputs.debounce_ms = 0: must be between 1 and 100"
        );
        let e = SetupFile::parse("[homing.axis.X]\nseek_rate = 0\n").unwrap_err();
        assert!(
            e.to_string().starts_with("homing.axis.X.seek_rate = 0"),
            "{e}"
        );
        let e = SetupFile::parse("[homing]\nbefore_seek = [\"set 99\"]\n").unwrap_err();
        assert!(e.to_string().starts_with("homing.before_seek[0]"), "{e}");
        let e = SetupFile::parse("[inputs]\nlimits_min = [\"A\"]\n").unwrap_err();
        assert!(e.to_string().starts_with("inputs.limits_min"), "{e}");
        let e = SetupFile::parse("[[mcode]]\ncode = 100\n").unwrap_err();
        assert!(e.to_string().contains("not in program.user_mcodes"), "{e}");
        let e = SetupFile::parse("[spindle]\nrpm_range = [5000, 100]\n").unwrap_err();
        assert!(e.to_string().starts_with("spindle.rpm_range"), "{e}");
    }

    #[test]
    fn controller_sections_round_trip() {
        let text = r#"
[program]
user_mcodes = [100, 101]
[inputs]
active_low = ["cycle_start1", "x_min", "in30"]
debounce_ms = 3
limits_min = ["X", "Y"]
limits_max = ["Z"]
hard_limits = true
fro_pot = true
[homing]
required = true
before_seek = ["set 1"]
before_retract = ["disable_limit_report", "dwell 250", "seek"]
after_retract = ["wait in30 high 2000", "clear 1"]
[homing.axis.X]
priority = 2
seek = "low"
seek_rate = 120.0
retract = 1.5
home_position = -3.25
[homing.axis.Z]
priority = 1
seek = "high"
[jog]
pair0 = ["Y", "X"]
pair1 = ["Z", "-"]
instant_speed = 50.0
nudge_distance = 0.005
analog_axes = ["X", "-"]
[spindle]
rpm_range = [6000, 24000]
pwm_range = [10, 999]
[[mcode]]
code = 101
dry_run_disabled = true
commands = ["set 4", "wait feed_hold low 100", "clear 4"]
[[mcode]]
code = 100
commands = ["clear 2"]
[link]
host_lost_stop_s = 0
"#;
        let s = SetupFile::parse(text).unwrap();
        assert_eq!(s.inputs.invert, (1 << 2) | (1 << 16) | (1 << 30));
        assert_eq!((s.inputs.limit_min, s.inputs.limit_max), (0b011, 0b100));
        assert_eq!(s.homing.axes[0].home_position, -3_250_000);
        assert_eq!(s.homing.axes[0].seek_rate, 120_000_000);
        assert!(!s.homing.axes[2].seek_low);
        assert_eq!(s.jog.pairs, [[1, 0], [2, 255]]);
        assert_eq!(s.jog.analog_axes, [0, 255]);
        assert_eq!(
            s.outputs.mcode_lists[0].commands[1],
            ListCommand::WaitInput {
                bit: 0,
                level: false,
                timeout_ms: 100
            }
        );
        assert_eq!(s.homing.before_retract[0], ListCommand::DisableLimitReport);
        assert_eq!(s.link.host_lost_stop_s, 0);
        assert!(s.is_valid());
        let shown = to_toml(&s);
        assert_eq!(SetupFile::parse(&shown).unwrap(), s);
        // `setup show` says which lists switch on the fly.
        assert!(
            shown.contains("commands = [\"clear 2\"]   # one output command: switched on the fly")
        );
        assert!(shown.contains("\"clear 4\"]   # runs at rest"));
    }

    #[test]
    fn the_limit_report_directive_must_come_first_and_the_host_timeout_is_bounded() {
        let e =
            SetupFile::parse("[homing]\nbefore_retract = [\"seek\", \"disable_limit_report\"]\n")
                .unwrap_err();
        assert_eq!(
            e.to_string(),
            "homing.before_retract[1]: \"disable_limit_report\" must be the first entry of its list"
        );
        assert_eq!(Setup::default().link.host_lost_stop_s, 60);
        let s = SetupFile::parse("[link]\nhost_lost_stop_s = 600\n").unwrap();
        assert_eq!(s.link.host_lost_stop_s, 600);
        assert!(SetupFile::parse("[link]\nhost_lost_stop_s = 70000\n").is_err());
        assert!(SetupFile::parse("[link]\nhost_timeout = 1\n").is_err());
    }

    #[test]
    fn driver_timing_is_read_in_microseconds_and_checked_against_the_step_rates() {
        assert_eq!(
            (
                Setup::default().drivers.step_pulse_ns,
                Setup::default().drivers.dir_setup_ns
            ),
            (2_500, 5_000)
        );
        let s = SetupFile::parse("[drivers]\nstep_pulse_us = 2.5\ndir_setup_us = 0.65\n").unwrap();
        assert_eq!(
            (s.drivers.step_pulse_ns, s.drivers.dir_setup_ns),
            (2_500, 650)
        );
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        assert!(to_toml(&s).contains("step_pulse_us = 2.5 "));
        let e = SetupFile::parse("[drivers]\nstep_pulse_us = 0.5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "drivers.step_pulse_us = 0.5: must be between 1 and 50 µs"
        );
        assert!(SetupFile::parse("[drivers]\ndir_setup_us = 51\n").is_err());
        assert!(SetupFile::parse("[drivers]\nstep_pulse = 5\n").is_err());
        // 3200 steps per 5 mm at 3000 mm/min is 32 000 steps/s (31.25 µs, 375 counts): a 15.5
        // µs pulse (186 counts) with as long a low time needs 31 µs and fits, whatever the dir
        // set-up (only a reversal waits for it); 15.6 µs (188 counts, 376) does not.
        assert!(SetupFile::parse("[drivers]\nstep_pulse_us = 15.5\ndir_setup_us = 50\n").is_ok());
        let e = SetupFile::parse("[drivers]\nstep_pulse_us = 15.6\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "axis.X.max_rate = 3000 mm/min is 32000 steps/s, but the drivers' step pulse \
             (15.6 µs, then low as long again) allows at most 31914 steps/s: lower max_rate or \
             drivers.step_pulse_us"
        );
    }

    #[test]
    fn the_door_spin_up_is_read_in_seconds_and_bounded() {
        assert_eq!(Setup::default().grbl.door_spin_up_ms, 4_000);
        assert!(to_toml(&Setup::default()).contains("door_spin_up_s = 4.0 "));
        let s = SetupFile::parse("[grbl]\ndoor_spin_up_s = 2.5\n").unwrap();
        assert_eq!(s.grbl.door_spin_up_ms, 2_500);
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        let s = SetupFile::parse("[grbl]\ndoor_spin_up_s = 0\n").unwrap();
        assert_eq!(s.grbl.door_spin_up_ms, 0);
        assert!(s.is_valid());
        let e = SetupFile::parse("[grbl]\ndoor_spin_up_s = 60.5\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "grbl.door_spin_up_s = 60.5: must be between 0 and 60 s"
        );
        assert!(SetupFile::parse("[grbl]\ndoor_spin_up_s = -1\n").is_err());
    }
}

/// The two walks against each other (the tests above are the file's behaviour, these its table).
#[cfg(test)]
mod walk_tests {
    use super::*;

    #[test]
    fn every_row_goes_through_the_file_and_back_at_both_ends_of_its_range() {
        let mut base = Setup::default();
        let tool = gantry_machine::setup::Tool {
            number: 1,
            length: 0,
            diameter: 0,
        };
        base.program.tools.push(tool).unwrap();
        let mut tried = 0;
        for r in ROWS.iter().filter(|r| r.unit != Unit::Text) {
            for i in 0..r.section.count(&base) {
                for v in [r.min(), r.max()] {
                    let mut s = base.clone();
                    r.key.set(&mut s, i, v);
                    // An end the rules between settings refuse (a start speed above the max
                    // rate…) cannot be written as a valid file.
                    if s.validate().is_err() {
                        continue;
                    }
                    tried += 1;
                    let back = SetupFile::parse(&to_toml(&s)).unwrap();
                    assert_eq!(back, s, "{:?}[{i}] = {v}", r.key);
                }
            }
        }
        assert!(tried > 150, "only {tried} row ends were valid setups");
    }
}

#[cfg(test)]
mod orient_tests {
    use super::*;

    #[test]
    fn the_orient_reads_writes_and_refuses_what_it_cannot_use() {
        let e = SetupFile::parse("[spindle]\norient_output = 16\n").unwrap_err();
        assert!(
            e.to_string().starts_with("spindle.orient_output = 16"),
            "{e}"
        );
        let e = SetupFile::parse("[spindle]\norient_dwell_ms = 100\n").unwrap_err();
        assert!(
            e.to_string().contains("set spindle.orient_output first"),
            "{e}"
        );
        let e = SetupFile::parse("[spindle]\norient_output = 1\norient_done_input = \"in40\"\n")
            .unwrap_err();
        assert!(
            e.to_string().starts_with("spindle.orient_done_input"),
            "{e}"
        );
        let s = SetupFile::parse(
            "[spindle]\norient_output = 7\norient_done_input = \"in21\"\norient_dwell_ms = 1500\n",
        )
        .unwrap();
        assert_eq!(
            s.outputs.orient,
            gantry_machine::setup::OrientSetup {
                output: 7,
                done_input: 21,
                dwell_ms: 1500
            }
        );
        assert!(s.interp_config().spindle_orient);
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        let d = Setup::default();
        assert_eq!(SetupFile::parse(&to_toml(&d)).unwrap(), d);
    }

    #[test]
    fn the_torch_settings_read_and_write_and_refuse_the_laser_beside_them() {
        let s = SetupFile::parse(
            "[spindle]\ntorch = true\narc_ok_timeout_ms = 500\nthc_rate = 600\nthc_travel = 2.5\n\
             thc_anti_dive = 80\nthc_delay_ms = 250\n",
        )
        .unwrap();
        let t = &s.outputs.torch;
        assert!(t.on && t.thc);
        assert_eq!(t.arc_ok_timeout_ms, 500);
        assert_eq!(t.thc_rate, 600 * gantry_machine::units::NM_PER_MM);
        assert_eq!(t.thc_travel, 2_500_000);
        assert_eq!((t.thc_anti_dive, t.thc_delay_ms), (80, 250));
        assert_eq!(SetupFile::parse(&to_toml(&s)).unwrap(), s);
        let e = SetupFile::parse("[spindle]\ntorch = true\nlaser = true\n").unwrap_err();
        assert!(e.to_string().contains("torch"), "{e}");
    }
}
