//! Value Change Dump (IEEE 1364 §18) traces of the emulated board's pins, for GTKWave or PulseView.
//!
//! The board (or the emulated board's kernel ticks) hands in [`VcdEvent`]s in time order: the
//! axes that step at that instant, the direction and enable levels, the input levels and the user
//! output levels, and in laser mode the laser PWM duty (a 16-bit `laser_pwm` vector, in compare
//! counts of `spindle.pwm_range[1]`). Each
//! step becomes a pulse: high at the event's time, low `pulse_ns` later. Only changes are
//! written, with a 1 ns timescale, optionally limited to a `--from/--to` window. [`read_vcd`] is a
//! small reader (enough for the tests and for checking a trace): it counts rising edges per signal.

use std::collections::{HashMap, VecDeque};
use std::io::{self, Write};

/// Axis letters, in axis-bit order.
const AXES: [&str; 6] = ["x", "y", "z", "a", "b", "c"];

/// The pins at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VcdEvent {
    /// Time since the trace started, ns (non-decreasing from event to event).
    pub time_ns: u64,
    /// Axes that put out a step pulse now (bit i = axis i).
    pub step: u8,
    /// Direction levels (bit i = axis i; 1 = the pin is high).
    pub dir: u8,
    /// Driver enable level.
    pub enable: bool,
    /// Input levels (bit i = input i).
    pub inputs: u32,
    /// User output levels (bit n = output n).
    pub outputs: u16,
    /// Laser PWM duty (written when [`VcdOptions::laser_pwm`] is set).
    pub pwm: u16,
}

/// Converts a time in step-kernel timer counts to ns, rounding to the nearest ns.
pub fn counts_to_ns(counts: u64, timer_hz: u32) -> u64 {
    ((counts as u128 * 1_000_000_000 + timer_hz as u128 / 2) / timer_hz as u128) as u64
}

/// Parses a `--from`/`--to` time: a number with `s`, `ms`, `us` (or `µs`) or `ns`; a bare
/// number is seconds. Returns ns.
pub fn parse_time_ns(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let (num, scale) = [
        ("ns", 1.0),
        ("us", 1e3),
        ("µs", 1e3),
        ("ms", 1e6),
        ("s", 1e9),
    ]
    .iter()
    .find_map(|(unit, scale)| t.strip_suffix(unit).map(|n| (n, *scale)))
    .unwrap_or((t, 1e9));
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("{text:?}: not a time (examples: 1.5s, 200ms, 50us, 800ns)"))?;
    if !v.is_finite() || v < 0.0 {
        return Err(format!("{text:?}: a time must be zero or positive"));
    }
    Ok((v * scale).round() as u64)
}

/// What to write.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VcdOptions {
    /// Number of axes (1..=6); each gets `<axis>_step` and `<axis>_dir`.
    pub axes: usize,
    /// Names of the input signals, bit 0 first (at most 32).
    pub inputs: Vec<String>,
    /// User outputs traced as `out0`, `out1`, … (at most 16).
    pub outputs: usize,
    /// Step pulse width, ns.
    pub pulse_ns: u64,
    /// Trace the laser PWM duty as the 16-bit vector `laser_pwm` (laser mode).
    pub laser_pwm: bool,
    /// Only changes at `from_ns..=to_ns` are written; the state at `from_ns` is the dump's start.
    pub from_ns: Option<u64>,
    pub to_ns: Option<u64>,
}

impl Default for VcdOptions {
    fn default() -> Self {
        VcdOptions {
            axes: 3,
            inputs: Vec::new(),
            outputs: 0,
            pulse_ns: 2_000,
            laser_pwm: false,
            from_ns: None,
            to_ns: None,
        }
    }
}

/// What was written.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VcdSummary {
    /// Rising edges written per axis.
    pub steps: [u64; 6],
    /// Steps that came while the axis' previous pulse was still high at the same instant and
    /// could not be shown as a separate pulse.
    pub merged: u64,
    /// Time of the last change written, ns.
    pub end_ns: u64,
}

/// Writes a VCD with `axes` axes, no named inputs, 2 µs pulses and no window.
pub fn write_vcd(
    out: &mut impl Write,
    axes: usize,
    events: impl Iterator<Item = VcdEvent>,
) -> io::Result<VcdSummary> {
    let opts = VcdOptions {
        axes,
        ..VcdOptions::default()
    };
    write_vcd_with(out, &opts, events)
}

/// VCD identifier of signal `n`: printable ASCII `!`..`~`, more characters past 94 signals.
fn ident(mut n: usize) -> String {
    let mut s = String::new();
    loop {
        s.push((b'!' + (n % 94) as u8) as char);
        n /= 94;
        if n == 0 {
            return s;
        }
        n -= 1;
    }
}

/// The signals in order: per axis step and dir, then enable, then the inputs, then the outputs.
struct Signals {
    axes: usize,
    inputs: usize,
    outputs: usize,
}

impl Signals {
    fn step(&self, axis: usize) -> usize {
        2 * axis
    }
    fn dir(&self, axis: usize) -> usize {
        2 * axis + 1
    }
    fn enable(&self) -> usize {
        2 * self.axes
    }
    fn input(&self, i: usize) -> usize {
        2 * self.axes + 1 + i
    }
    fn output(&self, n: usize) -> usize {
        2 * self.axes + 1 + self.inputs + n
    }
    fn count(&self) -> usize {
        2 * self.axes + 1 + self.inputs + self.outputs
    }
}

/// Emits changes at increasing times, within the window.
struct Emitter<W: Write> {
    out: W,
    ids: Vec<String>,
    /// Current level of every signal.
    level: Vec<bool>,
    /// Time of the last `#t` line, if any.
    stamped: Option<u64>,
    from: u64,
    to: u64,
    started: bool,
    summary: VcdSummary,
    /// The laser PWM vector's identifier and value, when traced.
    pwm: Option<(String, u16)>,
}

impl<W: Write> Emitter<W> {
    /// Starts the dump at `from` with the current levels.
    fn start(&mut self) -> io::Result<()> {
        if self.started {
            return Ok(());
        }
        self.started = true;
        writeln!(self.out, "#{}", self.from)?;
        self.stamped = Some(self.from);
        writeln!(self.out, "$dumpvars")?;
        for (id, l) in self.ids.iter().zip(&self.level) {
            writeln!(self.out, "{}{id}", u8::from(*l))?;
        }
        if let Some((id, v)) = &self.pwm {
            writeln!(self.out, "b{v:b} {id}")?;
        }
        writeln!(self.out, "$end")?;
        self.summary.end_ns = self.from;
        Ok(())
    }

    /// Sets a signal; returns whether a change was written.
    fn set(&mut self, t: u64, sig: usize, v: bool) -> io::Result<bool> {
        if self.level[sig] == v {
            return Ok(false);
        }
        if t >= self.from && !self.started {
            self.start()?;
        }
        self.level[sig] = v;
        if t < self.from || t > self.to {
            return Ok(false);
        }
        if self.stamped != Some(t) {
            writeln!(self.out, "#{t}")?;
            self.stamped = Some(t);
        }
        writeln!(self.out, "{}{}", u8::from(v), self.ids[sig])?;
        self.summary.end_ns = t;
        Ok(true)
    }

    /// Sets the laser PWM vector (if traced).
    fn set_pwm(&mut self, t: u64, v: u16) -> io::Result<()> {
        match &self.pwm {
            Some((_, old)) if *old != v => {}
            _ => return Ok(()),
        }
        if t >= self.from && !self.started {
            self.start()?;
        }
        let id = match self.pwm.as_mut() {
            Some((id, old)) => {
                *old = v;
                id.clone()
            }
            None => return Ok(()),
        };
        if t < self.from || t > self.to {
            return Ok(());
        }
        if self.stamped != Some(t) {
            writeln!(self.out, "#{t}")?;
            self.stamped = Some(t);
        }
        writeln!(self.out, "b{v:b} {id}")?;
        self.summary.end_ns = t;
        Ok(())
    }

    /// Ends the step pulses of the axes in `mask`.
    fn fall(&mut self, sig: &Signals, t: u64, mask: u8) -> io::Result<()> {
        for a in 0..sig.axes {
            if mask >> a & 1 == 1 {
                self.set(t, sig.step(a), false)?;
            }
        }
        Ok(())
    }
}

/// A VCD being written event by event (for callers that are handed events one at a time, like
/// the emulated board's tick observer). Call [`VcdWriter::finish`] at the end; dropping an
/// unfinished writer finishes it and ignores errors.
pub struct VcdWriter<W: Write> {
    em: Emitter<W>,
    sig: Signals,
    pulse: u64,
    mask: u8,
    /// Falling edges still to come, in time order (all pulses are equally wide).
    falls: VecDeque<(u64, u8)>,
    last_time: u64,
    finished: bool,
}

impl<W: Write> VcdWriter<W> {
    /// Writes the header ($timescale 1 ns, one `gantry` scope with `<axis>_step`, `<axis>_dir`,
    /// `enable`, an `inputs` scope and an `outputs` scope).
    pub fn new(mut out: W, opts: &VcdOptions) -> io::Result<Self> {
        if opts.axes == 0 || opts.axes > AXES.len() || opts.inputs.len() > 32 || opts.outputs > 16 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "a VCD trace has 1..=6 axes, at most 32 inputs and at most 16 outputs",
            ));
        }
        let sig = Signals {
            axes: opts.axes,
            inputs: opts.inputs.len(),
            outputs: opts.outputs,
        };
        let ids: Vec<String> = (0..sig.count()).map(ident).collect();
        writeln!(out, "$version Gantry emulated board $end")?;
        writeln!(out, "$timescale 1 ns $end")?;
        writeln!(out, "$scope module gantry $end")?;
        for (a, name) in AXES.iter().enumerate().take(opts.axes) {
            writeln!(out, "$var wire 1 {} {name}_step $end", ids[sig.step(a)])?;
            writeln!(out, "$var wire 1 {} {name}_dir $end", ids[sig.dir(a)])?;
        }
        writeln!(out, "$var wire 1 {} enable $end", ids[sig.enable()])?;
        let pwm = opts.laser_pwm.then(|| (ident(sig.count()), 0u16));
        if let Some((id, _)) = &pwm {
            writeln!(out, "$var wire 16 {id} laser_pwm $end")?;
        }
        if !opts.inputs.is_empty() {
            writeln!(out, "$scope module inputs $end")?;
            for (i, name) in opts.inputs.iter().enumerate() {
                let name: String = name
                    .chars()
                    .map(|c| if c.is_ascii_graphic() { c } else { '_' })
                    .collect();
                writeln!(out, "$var wire 1 {} {name} $end", ids[sig.input(i)])?;
            }
            writeln!(out, "$upscope $end")?;
        }
        if opts.outputs > 0 {
            writeln!(out, "$scope module outputs $end")?;
            for n in 0..opts.outputs {
                writeln!(out, "$var wire 1 {} out{n} $end", ids[sig.output(n)])?;
            }
            writeln!(out, "$upscope $end")?;
        }
        writeln!(out, "$upscope $end")?;
        writeln!(out, "$enddefinitions $end")?;
        Ok(VcdWriter {
            em: Emitter {
                out,
                level: vec![false; ids.len()],
                ids,
                stamped: None,
                from: opts.from_ns.unwrap_or(0),
                to: opts.to_ns.unwrap_or(u64::MAX),
                started: false,
                summary: VcdSummary::default(),
                pwm,
            },
            sig,
            pulse: opts.pulse_ns.max(1),
            mask: ((1u16 << opts.axes) - 1) as u8,
            falls: VecDeque::new(),
            last_time: 0,
            finished: false,
        })
    }

    /// Records the pins at one instant (times must not go backwards). Events after the window
    /// are accepted and ignored.
    pub fn event(&mut self, e: VcdEvent) -> io::Result<()> {
        if e.time_ns < self.last_time {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "VCD event at {} ns after one at {} ns",
                    e.time_ns, self.last_time
                ),
            ));
        }
        self.last_time = e.time_ns;
        let (em, sig) = (&mut self.em, &self.sig);
        // Pulses that end before this event.
        while let Some(&(t, m)) = self.falls.front() {
            if t >= e.time_ns {
                break;
            }
            self.falls.pop_front();
            em.fall(sig, t, m)?;
        }
        if e.time_ns > em.to {
            return Ok(());
        }
        // Pulses ending exactly now. An axis that steps again at this instant goes low 1 ns
        // earlier, so the two pulses stay apart; one that steps while its pulse is still high
        // cannot show a second pulse and is counted as merged.
        let mut ending = 0u8;
        while let Some(&(t, m)) = self.falls.front() {
            if t != e.time_ns {
                break;
            }
            self.falls.pop_front();
            ending |= m;
        }
        let step = e.step & self.mask;
        let high = self.falls.iter().fold(0u8, |acc, (_, m)| acc | m);
        em.summary.merged += u64::from((step & high).count_ones());
        let earlier = e.time_ns.saturating_sub(1).max(em.stamped.unwrap_or(0));
        em.fall(sig, earlier, ending & step)?;
        em.fall(sig, e.time_ns, ending & !step)?;
        for a in 0..sig.axes {
            em.set(e.time_ns, sig.dir(a), e.dir >> a & 1 == 1)?;
        }
        em.set(e.time_ns, sig.enable(), e.enable)?;
        for i in 0..sig.inputs {
            em.set(e.time_ns, sig.input(i), e.inputs >> i & 1 == 1)?;
        }
        for n in 0..sig.outputs {
            em.set(e.time_ns, sig.output(n), e.outputs >> n & 1 == 1)?;
        }
        em.set_pwm(e.time_ns, e.pwm)?;
        let rise = step & !high;
        for a in 0..sig.axes {
            if rise >> a & 1 == 1 && em.set(e.time_ns, sig.step(a), true)? {
                em.summary.steps[a] += 1;
            }
        }
        if rise != 0 {
            self.falls.push_back((e.time_ns + self.pulse, rise));
        }
        Ok(())
    }

    /// Ends the last pulses, flushes and returns the summary.
    pub fn finish(mut self) -> io::Result<VcdSummary> {
        self.end()?;
        Ok(self.em.summary.clone())
    }

    fn end(&mut self) -> io::Result<()> {
        if self.finished {
            return Ok(());
        }
        self.finished = true;
        while let Some((t, m)) = self.falls.pop_front() {
            if t > self.em.to {
                break;
            }
            self.em.fall(&self.sig, t, m)?;
        }
        self.falls.clear();
        if !self.em.started {
            self.em.start()?;
        }
        self.em.out.flush()
    }
}

impl<W: Write> Drop for VcdWriter<W> {
    fn drop(&mut self) {
        let _ = self.end();
    }
}

/// Writes a VCD of `events` with the given options.
pub fn write_vcd_with(
    out: &mut impl Write,
    opts: &VcdOptions,
    events: impl Iterator<Item = VcdEvent>,
) -> io::Result<VcdSummary> {
    let mut w = VcdWriter::new(out, opts)?;
    for e in events {
        if e.time_ns > w.em.to {
            break;
        }
        w.event(e)?;
    }
    w.finish()
}

/// A parsed VCD: signal names and their rising edges.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VcdTrace {
    /// Signal reference names in declaration order.
    pub signals: Vec<String>,
    /// Rising edges (0 → 1 after the initial dump) per signal name.
    pub rising: HashMap<String, u64>,
    /// Times of those rising edges per 1-bit signal name.
    pub rise_times: HashMap<String, Vec<u64>>,
    /// Every value of each vector signal (wider than 1 bit): (time, value), the initial dump's
    /// first.
    pub values: HashMap<String, Vec<(u64, u64)>>,
    /// Level of each signal at the end.
    pub(crate) last: HashMap<String, bool>,
    /// Timescale text, e.g. `1 ns`.
    pub timescale: String,
    /// Last timestamp.
    pub end_time: u64,
}

/// Reads a VCD of 1-bit signals (what [`write_vcd_with`] writes, and most logic-analyser dumps).
pub fn read_vcd(text: &str) -> Result<VcdTrace, String> {
    let mut t = VcdTrace::default();
    let mut by_id: HashMap<String, String> = HashMap::new();
    let mut level: HashMap<String, Option<bool>> = HashMap::new();
    let mut toks = text.split_whitespace().peekable();
    let mut in_defs = true;
    let mut in_dump = false;
    let mut last_time = None;
    let mut vectors: HashMap<String, String> = HashMap::new();
    while let Some(tok) = toks.next() {
        if in_defs {
            match tok {
                "$var" => {
                    let f: Vec<&str> = toks.by_ref().take_while(|w| *w != "$end").collect();
                    if f.len() < 4 {
                        return Err(format!("bad $var: {f:?}"));
                    }
                    if f[1] != "1" {
                        vectors.insert(f[2].to_string(), f[3].to_string());
                        t.values.insert(f[3].to_string(), Vec::new());
                        t.signals.push(f[3].to_string());
                        continue;
                    }
                    by_id.insert(f[2].to_string(), f[3].to_string());
                    t.signals.push(f[3].to_string());
                    t.rising.insert(f[3].to_string(), 0);
                }
                "$timescale" => {
                    let f: Vec<&str> = toks.by_ref().take_while(|w| *w != "$end").collect();
                    t.timescale = f.join(" ");
                }
                "$enddefinitions" => {
                    toks.next();
                    in_defs = false;
                }
                w if w.starts_with('$') => {
                    for w in toks.by_ref() {
                        if w == "$end" {
                            break;
                        }
                    }
                }
                other => return Err(format!("unexpected {other:?} in the header")),
            }
            continue;
        }
        match tok {
            "$dumpvars" => in_dump = true,
            "$end" => in_dump = false,
            "$dumpall" | "$dumpon" | "$dumpoff" => {}
            w if w.starts_with('b') || w.starts_with('B') => {
                let v = u64::from_str_radix(&w[1..], 2).map_err(|_| format!("bad vector {w}"))?;
                let id = toks.next().ok_or("vector value without identifier")?;
                let name = vectors
                    .get(id)
                    .ok_or_else(|| format!("unknown vector identifier {id}"))?;
                if let Some(values) = t.values.get_mut(name) {
                    values.push((last_time.unwrap_or(0), v));
                }
            }
            w if w.starts_with('#') => {
                let v: u64 = w[1..].parse().map_err(|_| format!("bad time {w}"))?;
                if last_time.is_some_and(|l| v < l) {
                    return Err(format!("time goes backwards at {w}"));
                }
                last_time = Some(v);
                t.end_time = v;
            }
            w => {
                let (v, id) = w.split_at(1);
                let v = match v {
                    "0" => Some(false),
                    "1" => Some(true),
                    "x" | "X" | "z" | "Z" => None,
                    _ => return Err(format!("unsupported value change {w}")),
                };
                let name = by_id
                    .get(id)
                    .ok_or_else(|| format!("unknown identifier {id}"))?;
                let prev = level.insert(name.clone(), v).flatten();
                if !in_dump && prev == Some(false) && v == Some(true) {
                    *t.rising.entry(name.clone()).or_default() += 1;
                    t.rise_times
                        .entry(name.clone())
                        .or_default()
                        .push(last_time.unwrap_or(0));
                }
                if let Some(b) = v {
                    t.last.insert(name.clone(), b);
                }
            }
        }
    }
    if in_defs {
        return Err("no $enddefinitions".into());
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(time_ns: u64, step: u8, dir: u8) -> VcdEvent {
        VcdEvent {
            time_ns,
            step,
            dir,
            enable: true,
            inputs: 0,
            outputs: 0,
            pwm: 0,
        }
    }

    #[test]
    fn identifiers_are_unique_and_printable() {
        let ids: Vec<String> = (0..500).map(ident).collect();
        let set: std::collections::HashSet<_> = ids.iter().collect();
        assert_eq!(set.len(), 500);
        assert!(ids.iter().all(|s| s.chars().all(|c| c.is_ascii_graphic())));
    }

    #[test]
    fn pulses_and_header() {
        let mut out = Vec::new();
        let s = write_vcd(
            &mut out,
            2,
            [ev(0, 0b01, 0b10), ev(10_000, 0b11, 0)].into_iter(),
        )
        .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.contains("$timescale 1 ns $end"));
        assert!(text.contains("$var wire 1 ! x_step $end"));
        assert!(text.contains("$enddefinitions $end"));
        assert!(text.contains("#2000\n0!"), "{text}");
        assert_eq!(s.steps[..2], [2, 1]);
        let r = read_vcd(&text).unwrap();
        assert_eq!(r.rising["x_step"], 2);
        assert_eq!(r.rising["y_step"], 1);
        assert_eq!(r.rising["enable"], 1);
        assert!(!r.last["x_step"]);
        assert_eq!(r.end_time, 12_000);
    }

    #[test]
    fn back_to_back_pulses_stay_separate() {
        // A step exactly when the previous pulse ends: low one ns earlier, high again now.
        let mut out = Vec::new();
        let opts = VcdOptions {
            axes: 1,
            pulse_ns: 1000,
            ..Default::default()
        };
        let s = write_vcd_with(
            &mut out,
            &opts,
            [ev(0, 1, 0), ev(1000, 1, 0), ev(1500, 1, 0)].into_iter(),
        )
        .unwrap();
        let r = read_vcd(std::str::from_utf8(&out).unwrap()).unwrap();
        // The third step comes while the second pulse is high: merged, not shown.
        assert_eq!(r.rising["x_step"] + s.merged, 3);
        assert_eq!(s.merged, 1);
    }

    #[test]
    fn window_keeps_only_its_changes() {
        let events = (0..100u64).map(|i| ev(i * 10_000, 1, 1));
        let mut out = Vec::new();
        let opts = VcdOptions {
            axes: 1,
            from_ns: Some(250_000),
            to_ns: Some(500_000),
            ..Default::default()
        };
        write_vcd_with(&mut out, &opts, events).unwrap();
        let text = String::from_utf8(out).unwrap();
        let r = read_vcd(&text).unwrap();
        // Steps at 250 µs … 500 µs.
        assert_eq!(r.rising["x_step"], 26);
        assert!(text.contains("#250000\n$dumpvars"));
        assert_eq!(r.end_time, 500_000);
    }

    #[test]
    fn window_times() {
        assert_eq!(parse_time_ns("1.5s"), Ok(1_500_000_000));
        assert_eq!(parse_time_ns("2"), Ok(2_000_000_000));
        assert_eq!(parse_time_ns("200ms"), Ok(200_000_000));
        assert_eq!(parse_time_ns("50us"), Ok(50_000));
        assert_eq!(parse_time_ns("50µs"), Ok(50_000));
        assert_eq!(parse_time_ns("800 ns"), Ok(800));
        assert!(parse_time_ns("-1s").is_err());
        assert!(parse_time_ns("soon").is_err());
    }

    #[test]
    fn kernel_counts() {
        assert_eq!(counts_to_ns(24_000_000, 24_000_000), 1_000_000_000);
        assert_eq!(counts_to_ns(1, 24_000_000), 42);
    }
}
