//! Guided probing on the board's own G38.2 (docs/probing.md "Workflows"): one function per
//! workflow on a [`Session`]. A workflow is a few small jobs (MDI blocks, as `gantry mdi` sends
//! them); between them the exact latched contact (`Status::probe`, machine nm, to the step) is
//! read, and at the end the active work system's offset (`G10 L2`) or a tool's length (`G10 L1`,
//! then `G43 H`) is set so that the coordinates read what the workflow promises. [`Probe::plan`]
//! says in words what it will do; the client shows it and asks before calling [`Session::probe`].
//!
//! Every position here is machine mm. Nothing is retried and nothing resumes by itself: a probe
//! without contact ends its job in alarm 5 and the workflow stops with that alarm's words.

use super::{Flow, Session};
use gantry_proto::Status;

/// The direction a single probe move goes (and so which face of the part it touches).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Towards +X: the part's left face.
    XPlus,
    /// Towards −X: the part's right face.
    XMinus,
    /// Towards +Y: the part's front face.
    YPlus,
    /// Towards −Y: the part's back face.
    YMinus,
}

impl Side {
    /// Reads `x+`, `x-`, `y+`, `y-`.
    pub(crate) fn parse(text: &str) -> Option<Side> {
        Some(match text {
            "x+" => Side::XPlus,
            "x-" => Side::XMinus,
            "y+" => Side::YPlus,
            "y-" => Side::YMinus,
            _ => return None,
        })
    }

    fn axis(self) -> usize {
        match self {
            Side::XPlus | Side::XMinus => 0,
            Side::YPlus | Side::YMinus => 1,
        }
    }

    /// +1 or −1: the probe move's sign on its axis.
    fn sign(self) -> f64 {
        match self {
            Side::XPlus | Side::YPlus => 1.0,
            Side::XMinus | Side::YMinus => -1.0,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Side::XPlus => "X+",
            Side::XMinus => "X-",
            Side::YPlus => "Y+",
            Side::YMinus => "Y-",
        }
    }

    fn face(self) -> &'static str {
        match self {
            Side::XPlus => "left face",
            Side::XMinus => "right face",
            Side::YPlus => "front face",
            Side::YMinus => "back face",
        }
    }

    fn away(self) -> &'static str {
        match self {
            Side::XPlus => "to the left",
            Side::XMinus => "to the right",
            Side::YPlus => "in front",
            Side::YMinus => "behind",
        }
    }
}

/// An outside corner of the part, seen from above with X to the right and Y away from the
/// operator; it is probed on its X face and then its Y face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corner {
    FrontLeft,
    FrontRight,
    BackLeft,
    BackRight,
}

impl Corner {
    /// Reads `front-left`, `front-right`, `back-left`, `back-right`.
    pub(crate) fn parse(text: &str) -> Option<Corner> {
        Some(match text {
            "front-left" => Corner::FrontLeft,
            "front-right" => Corner::FrontRight,
            "back-left" => Corner::BackLeft,
            "back-right" => Corner::BackRight,
            _ => return None,
        })
    }

    /// The two probe moves: the X face, then the Y face.
    fn sides(self) -> [Side; 2] {
        match self {
            Corner::FrontLeft => [Side::XPlus, Side::YPlus],
            Corner::FrontRight => [Side::XMinus, Side::YPlus],
            Corner::BackLeft => [Side::XPlus, Side::YMinus],
            Corner::BackRight => [Side::XMinus, Side::YMinus],
        }
    }

    fn name(self) -> &'static str {
        match self {
            Corner::FrontLeft => "front-left",
            Corner::FrontRight => "front-right",
            Corner::BackLeft => "back-left",
            Corner::BackRight => "back-right",
        }
    }
}

/// How the sideways workflows (edge, corner, boss) reach a face from above the part.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Approach {
    /// How far out beside the start the tool goes down, mm.
    pub clearance: f64,
    /// How far below the start it goes down, mm.
    pub depth: f64,
    /// The tool's diameter, mm (its radius is added to each contact).
    pub diameter: f64,
}

/// One workflow, with its numbers (mm, mm/min) already validated by the client.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Probe {
    /// Z from a touch plate of `thickness` on the work: probe down up to `distance`.
    Z {
        thickness: f64,
        distance: f64,
        feed: f64,
        retract: f64,
    },
    /// One face, X or Y: that axis's zero at the face.
    Edge {
        side: Side,
        approach: Approach,
        feed: f64,
        retract: f64,
    },
    /// An outside corner: X and Y zero at the corner.
    Corner {
        corner: Corner,
        approach: Approach,
        feed: f64,
        retract: f64,
    },
    /// The centre of a bore (the tool in it, below its top): ±X, then ±Y through the X centre;
    /// X0 Y0 at the centre. `size`: the bore's diameter at most (each probe's reach).
    Bore {
        size: f64,
        diameter: f64,
        feed: f64,
        retract: f64,
    },
    /// The centre of a boss (the tool above it): each side from outside, X then Y through the X
    /// centre; X0 Y0 at the centre. `size`: the boss's diameter at most.
    Boss {
        size: f64,
        approach: Approach,
        feed: f64,
        retract: f64,
    },
    /// The length of `tool` against the tool setter over which the setup's G30 position
    /// (`program.g30_home`) stands: probe down up to `distance` from that position; the
    /// length is the contact less `setter_z`, the machine Z at which a tool of length 0 (the
    /// spindle's gauge line) touches the setter.
    ToolLength {
        tool: u32,
        setter_z: f64,
        distance: f64,
        feed: f64,
        retract: f64,
    },
}

/// The far side of a probe move beyond where the face should be: the tool starts "a few mm"
/// inside the edge, so a reach of the clearance and this much finds it.
const EDGE_MARGIN_MM: f64 = 5.0;

impl Probe {
    /// What the workflow will do, in words, for the operator to confirm; `system` is the active
    /// work system (G54 …), `g30` the setup's G30 position (machine mm).
    pub(crate) fn plan(&self, system: &str, g30: [f64; 3]) -> String {
        let nc = "Without contact the board stops in alarm 5.";
        match *self {
            Probe::Z {
                thickness,
                distance,
                feed,
                retract,
            } => format!(
                "Z touch plate ({thickness} mm thick, on the work):\n\
                 1. probe down up to {distance} mm at {feed} mm/min (G38.2) until the tool touches the plate\n\
                 2. set {system} Z so that work Z = {thickness} at the contact (Z0 = the work's top)\n\
                 3. back up {retract} mm\n\
                 The plate must be under the tool and its clip on; {}",
                nc.to_lowercase()
            ),
            Probe::Edge {
                side,
                approach: a,
                feed,
                retract,
            } => format!(
                "XY edge, probing {} (the {}), the tool above the part a few mm inside the edge:\n\
                 1. rapid {} mm {}, down {} mm, probe {} up to {} mm at {feed} mm/min\n\
                 2. back {retract} mm, up, and above the start again\n\
                 3. set {system} {} so that the face is work {}0 (tool diameter {} mm)\n{nc}",
                side.name(),
                side.face(),
                a.clearance,
                side.away(),
                a.depth,
                side.name(),
                a.clearance + EDGE_MARGIN_MM,
                axis_name(side.axis()),
                axis_name(side.axis()),
                a.diameter
            ),
            Probe::Corner {
                corner,
                approach: a,
                feed,
                retract,
            } => {
                let [sx, sy] = corner.sides();
                format!(
                    "XY outside corner ({}), the tool above the part a few mm inside the corner:\n\
                     1. rapid {} mm {}, down {} mm, probe {} up to {} mm at {feed} mm/min\n\
                     2. back {retract} mm, up, above the start, {} mm {}, down, probe {} the same way\n\
                     3. back {retract} mm, up, and above the start again\n\
                     4. set {system} X and Y so that the corner is work X0 Y0 (tool diameter {} mm)\n{nc}",
                    corner.name(),
                    a.clearance,
                    sx.away(),
                    a.depth,
                    sx.name(),
                    a.clearance + EDGE_MARGIN_MM,
                    a.clearance,
                    sy.away(),
                    sy.name(),
                    a.diameter
                )
            }
            Probe::Bore {
                size,
                diameter,
                feed,
                retract,
            } => format!(
                "Bore centre, the tool in the bore below its top (nothing moves in Z):\n\
                 1. probe X+ and X- up to {size} mm each at {feed} mm/min, back to the start after each\n\
                 2. to the X centre, probe Y+ and Y- the same way, then to the centre\n\
                 3. set {system} X and Y so that the centre is work X0 Y0; report the diameter (tool diameter {diameter} mm)\n\
                 Each contact backs off {retract} mm first. {nc}"
            ),
            Probe::Boss {
                size,
                approach: a,
                feed,
                retract,
            } => format!(
                "Boss centre, the tool above the boss near its centre:\n\
                 1. rapid {} mm out to the left (half of {size} mm and {} mm), down {} mm, probe X+ at {feed} mm/min, back {retract} mm, up\n\
                 2. the same from the right (X-), then to the X centre\n\
                 3. the same in front (Y+) and behind (Y-), then above the centre\n\
                 4. set {system} X and Y so that the centre is work X0 Y0; report the diameter (tool diameter {} mm)\n{nc}",
                size / 2.0 + a.clearance,
                a.clearance,
                a.depth,
                a.diameter
            ),
            Probe::ToolLength {
                tool,
                setter_z,
                distance,
                feed,
                retract,
            } => format!(
                "Tool length of T{tool} on the tool setter (the setup's G30 position, machine X {:.3} Y {:.3} Z {:.3}):\n\
                 1. up to machine Z {:.3} if lower, rapid over the setter, down to Z {:.3}\n\
                 2. probe down up to {distance} mm at {feed} mm/min until the tool touches the setter\n\
                 3. tool T{tool}'s length = the contact less Z {setter_z:.3} (where a tool of length 0 touches): G10 L1 P{tool}, then G43 H{tool}\n\
                 4. back up to Z {:.3} (at least {retract} mm)\n{nc}",
                g30[0], g30[1], g30[2], g30[2], g30[2], g30[2]
            ),
        }
    }
}

fn axis_name(axis: usize) -> &'static str {
    ["X", "Y", "Z"][axis]
}

fn mm(nm: i64) -> f64 {
    nm as f64 / 1e6
}

/// The latched contact of the last probe move, machine mm; an error without contact.
fn contact(st: &Status) -> Result<[f64; 3], String> {
    match st.probe {
        Some(p) if p.success => Ok([0, 1, 2].map(|i| mm(p.machine_pos[i]))),
        _ => Err("the probe did not touch".into()),
    }
}

/// Where a workflow started and what lies between machine and work coordinates there.
struct Start {
    /// Machine position, mm.
    at: [f64; 3],
    /// The active work system, 0 = G54.
    ws: usize,
    system: &'static str,
    /// The active system's offset, nm.
    offset: [i64; 3],
}

impl Start {
    /// The offset to write so that machine `m` on `axis` reads `work` in work coordinates,
    /// keeping what lies between machine and work besides the system's offset (G92, tool
    /// length) as it is in `st`.
    fn offset_for(&self, st: &Status, axis: usize, m: f64, work: f64) -> f64 {
        let other = mm(st.machine_pos[axis] - st.work_pos[axis] - self.offset[axis]);
        m - work - other
    }
}

impl Session {
    /// One step of a workflow: blocks run as one job, nothing refused, no alarm; the status after.
    fn probe_step(&mut self, blocks: &[String]) -> Result<Status, String> {
        let (program, report) = self
            .mdi(blocks, &mut |_| Flow::Continue)
            .map_err(|e| format!("{e:#}"))?;
        if let Some(e) = report.errors.first() {
            return Err(e.describe("probe", &program));
        }
        if let Some(a) = report.alarms.first() {
            return Err(a.describe(&program));
        }
        if !report.completed {
            return Err("the probing job did not complete (held, aborted or the link lost)".into());
        }
        self.status().map_err(|e| format!("{e:#}"))
    }

    /// Where the workflow starts; the board's setup read again first, for the offsets an
    /// earlier job (another workflow, a program's G10) set.
    fn probe_start(&mut self) -> Result<Start, String> {
        self.reload_setup().map_err(|e| format!("{e:#}"))?;
        let st = self.status().map_err(|e| format!("{e:#}"))?;
        let ws = usize::from(st.work_system);
        let o = self.setup().program.work_offsets[ws];
        Ok(Start {
            at: [0, 1, 2].map(|i| mm(st.machine_pos[i])),
            ws,
            system: crate::present::work_system_name(st.work_system),
            offset: [o[0], o[1], o[2]],
        })
    }

    /// Probes `side` towards the part from `from` (machine mm, above the part): out by `out`
    /// beside it, down by `depth`, probe up to `reach`, back by `retract`, up, and above `from`
    /// again. Returns the contact on the side's axis and the status at the contact.
    #[allow(clippy::too_many_arguments)]
    fn touch_face(
        &mut self,
        from: [f64; 3],
        side: Side,
        out: f64,
        depth: f64,
        reach: f64,
        feed: f64,
        retract: f64,
    ) -> Result<(f64, Status), String> {
        let (a, d) = (axis_name(side.axis()), side.sign());
        let st = self.probe_step(&[
            format!("G21 G90 G53 G0 {a}{:.4}", from[side.axis()] - d * out),
            format!("G53 G0 Z{:.4}", from[2] - depth),
            format!("G91 G38.2 {a}{:.4} F{feed:.1}", d * reach),
            "G90".into(),
        ])?;
        let c = contact(&st)?[side.axis()];
        self.probe_step(&[
            format!("G21 G90 G53 G0 {a}{:.4}", c - d * retract),
            format!("G53 G0 Z{:.4}", from[2]),
            format!("G53 G0 X{:.4} Y{:.4}", from[0], from[1]),
        ])?;
        Ok((c, st))
    }

    /// Probes `side` from where the tool is (no Z move) up to `reach`, backs off by
    /// `retract` and returns to `from`. Returns the contact on the side's axis.
    fn touch_inside(
        &mut self,
        from: [f64; 3],
        side: Side,
        reach: f64,
        feed: f64,
        retract: f64,
    ) -> Result<(f64, Status), String> {
        let (a, d) = (axis_name(side.axis()), side.sign());
        let st = self.probe_step(&[
            format!("G21 G91 G38.2 {a}{:.4} F{feed:.1}", d * reach),
            "G90".into(),
        ])?;
        let c = contact(&st)?[side.axis()];
        self.probe_step(&[
            format!("G21 G90 G53 G0 {a}{:.4}", c - d * retract),
            format!("G53 G0 X{:.4} Y{:.4}", from[0], from[1]),
        ])?;
        Ok((c, st))
    }

    /// Runs `probe` (the board at rest, Idle); returns the report: what was measured and which
    /// offset was set.
    pub(crate) fn probe(&mut self, probe: &Probe) -> Result<String, String> {
        match *probe {
            Probe::Z {
                thickness,
                distance,
                feed,
                retract,
            } => self.probe_z(thickness, distance, feed, retract),
            Probe::Edge {
                side,
                approach,
                feed,
                retract,
            } => self.probe_edge(side, approach, feed, retract),
            Probe::Corner {
                corner,
                approach,
                feed,
                retract,
            } => self.probe_corner(corner, approach, feed, retract),
            Probe::Bore {
                size,
                diameter,
                feed,
                retract,
            } => self.probe_bore(size, diameter, feed, retract),
            Probe::Boss {
                size,
                approach,
                feed,
                retract,
            } => self.probe_boss(size, approach, feed, retract),
            Probe::ToolLength {
                tool,
                setter_z,
                distance,
                feed,
                retract,
            } => self.probe_tool_length(tool, setter_z, distance, feed, retract),
        }
    }

    /// Z touch plate: probe down until the tool touches a plate of `thickness` on the work; work
    /// Z is then `thickness` at the contact (Z0 = the work's top); back up by `retract`.
    pub(crate) fn probe_z(
        &mut self,
        thickness: f64,
        distance: f64,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let st = self.probe_step(&[
            format!("G21 G91 G38.2 Z-{distance:.4} F{feed:.1}"),
            "G90".into(),
        ])?;
        let c = contact(&st)?;
        let z = s0.offset_for(&st, 2, c[2], thickness);
        self.probe_step(&[
            format!("G21 G90 G10 L2 P{} Z{z:.4}", s0.ws + 1),
            format!("G53 G0 Z{:.4}", c[2] + retract),
        ])?;
        Ok(format!(
            "Z touch plate: contact at machine Z {:.3}; {} Z set to {z:.3} (work Z {thickness:.3} at the plate's top, 0 at the work's top)",
            c[2], s0.system
        ))
    }

    /// XY edge: one face from outside; that axis's zero at the face (the tool's radius added).
    pub fn probe_edge(
        &mut self,
        side: Side,
        a: Approach,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let reach = a.clearance + EDGE_MARGIN_MM;
        let (c, st) = self.touch_face(s0.at, side, a.clearance, a.depth, reach, feed, retract)?;
        let face = c + side.sign() * a.diameter / 2.0;
        let axis = side.axis();
        let v = s0.offset_for(&st, axis, face, 0.0);
        let n = axis_name(axis);
        self.probe_step(&[format!("G21 G90 G10 L2 P{} {n}{v:.4}", s0.ws + 1)])?;
        Ok(format!(
            "XY edge {}: contact at machine {n} {c:.3} ({}); the face at machine {n} {face:.3}; {} {n} set to {v:.3}",
            side.name(),
            side.face(),
            s0.system
        ))
    }

    /// XY outside corner: its X face, then its Y face; X0 Y0 at the corner.
    pub fn probe_corner(
        &mut self,
        corner: Corner,
        a: Approach,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let reach = a.clearance + EDGE_MARGIN_MM;
        let [sx, sy] = corner.sides();
        let (cx, _) = self.touch_face(s0.at, sx, a.clearance, a.depth, reach, feed, retract)?;
        let (cy, st) = self.touch_face(s0.at, sy, a.clearance, a.depth, reach, feed, retract)?;
        let r = a.diameter / 2.0;
        let (ex, ey) = (cx + sx.sign() * r, cy + sy.sign() * r);
        let (x, y) = (
            s0.offset_for(&st, 0, ex, 0.0),
            s0.offset_for(&st, 1, ey, 0.0),
        );
        self.probe_step(&[format!("G21 G90 G10 L2 P{} X{x:.4} Y{y:.4}", s0.ws + 1)])?;
        Ok(format!(
            "XY corner ({}): contacts at machine X {cx:.3} ({}) and Y {cy:.3} ({}); the corner at machine X {ex:.3} Y {ey:.3}; {} X set to {x:.3}, Y to {y:.3}",
            corner.name(),
            sx.face(),
            sy.face(),
            s0.system
        ))
    }

    /// Bore centre: ±X from the start, then ±Y through the X centre (a chord's middle is on the
    /// centre line whatever the chord, so the Y chord is the diameter); X0 Y0 at the centre.
    pub fn probe_bore(
        &mut self,
        size: f64,
        diameter: f64,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let from = s0.at;
        let (x1, _) = self.touch_inside(from, Side::XPlus, size, feed, retract)?;
        let (x0, _) = self.touch_inside(from, Side::XMinus, size, feed, retract)?;
        let cx = (x0 + x1) / 2.0;
        let mid = [cx, from[1], from[2]];
        self.probe_step(&[format!("G21 G90 G53 G0 X{cx:.4}")])?;
        let (y1, _) = self.touch_inside(mid, Side::YPlus, size, feed, retract)?;
        let (y0, st) = self.touch_inside(mid, Side::YMinus, size, feed, retract)?;
        let cy = (y0 + y1) / 2.0;
        let (x, y) = (
            s0.offset_for(&st, 0, cx, 0.0),
            s0.offset_for(&st, 1, cy, 0.0),
        );
        self.probe_step(&[
            format!("G21 G90 G53 G0 Y{cy:.4}"),
            format!("G10 L2 P{} X{x:.4} Y{y:.4}", s0.ws + 1),
        ])?;
        Ok(format!(
            "Bore: contacts at machine X {x0:.3} and {x1:.3}, Y {y0:.3} and {y1:.3}; the centre at machine X {cx:.3} Y {cy:.3}, diameter {:.3} (X chord {:.3}); {} X set to {x:.3}, Y to {y:.3}; the tool is over the centre",
            y1 - y0 + diameter,
            x1 - x0 + diameter,
            s0.system
        ))
    }

    /// Boss centre: each side from outside, X then Y through the X centre; X0 Y0 at the centre.
    pub fn probe_boss(
        &mut self,
        size: f64,
        a: Approach,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let out = size / 2.0 + a.clearance;
        let from = s0.at;
        let (x0, _) = self.touch_face(from, Side::XPlus, out, a.depth, out, feed, retract)?;
        let (x1, _) = self.touch_face(from, Side::XMinus, out, a.depth, out, feed, retract)?;
        let cx = (x0 + x1) / 2.0;
        let mid = [cx, from[1], from[2]];
        self.probe_step(&[format!("G21 G90 G53 G0 X{cx:.4}")])?;
        let (y0, _) = self.touch_face(mid, Side::YPlus, out, a.depth, out, feed, retract)?;
        let (y1, st) = self.touch_face(mid, Side::YMinus, out, a.depth, out, feed, retract)?;
        let cy = (y0 + y1) / 2.0;
        let (x, y) = (
            s0.offset_for(&st, 0, cx, 0.0),
            s0.offset_for(&st, 1, cy, 0.0),
        );
        self.probe_step(&[
            format!("G21 G90 G53 G0 Y{cy:.4}"),
            format!("G10 L2 P{} X{x:.4} Y{y:.4}", s0.ws + 1),
        ])?;
        Ok(format!(
            "Boss: contacts at machine X {x0:.3} and {x1:.3}, Y {y0:.3} and {y1:.3}; the centre at machine X {cx:.3} Y {cy:.3}, diameter {:.3} (X chord {:.3}); {} X set to {x:.3}, Y to {y:.3}; the tool is above the centre",
            y1 - y0 - a.diameter,
            x1 - x0 - a.diameter,
            s0.system
        ))
    }

    /// Tool length on the tool setter under the setup's G30 position: the length of `tool` is
    /// the contact less `setter_z`; it goes into the board's tool table (`G10 L1`) and is applied
    /// (`G43 H`), so the work Z of this tool reads as for every other measured tool.
    pub fn probe_tool_length(
        &mut self,
        tool: u32,
        setter_z: f64,
        distance: f64,
        feed: f64,
        retract: f64,
    ) -> Result<String, String> {
        let s0 = self.probe_start()?;
        let g = self.setup().program.g30_home;
        let over = [mm(g[0]), mm(g[1]), mm(g[2])];
        let up = s0.at[2].max(over[2]);
        let st = self.probe_step(&[
            format!("G21 G90 G53 G0 Z{up:.4}"),
            format!("G53 G0 X{:.4} Y{:.4}", over[0], over[1]),
            format!("G53 G0 Z{:.4}", over[2]),
            format!("G91 G38.2 Z-{distance:.4} F{feed:.1}"),
            "G90".into(),
        ])?;
        let c = contact(&st)?[2];
        let length = c - setter_z;
        self.probe_step(&[
            format!("G21 G90 G53 G0 Z{:.4}", over[2].max(c + retract)),
            format!("G10 L1 P{tool} Z{length:.4}"),
            format!("G43 H{tool}"),
        ])?;
        Ok(format!(
            "Tool length: contact on the setter at machine Z {c:.3}; T{tool} length set to {length:.3} (G10 L1 P{tool}) and applied (G43 H{tool})"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plans_name_their_moves() {
        let a = Approach {
            clearance: 12.0,
            depth: 8.0,
            diameter: 3.0,
        };
        let g30 = [385.0, 25.0, 20.0];
        let corner = Probe::Corner {
            corner: Corner::BackRight,
            approach: a,
            feed: 100.0,
            retract: 2.0,
        };
        let p = corner.plan("G55", g30);
        assert!(
            p.contains("(back-right)") && p.contains("probe X- up to 17 mm"),
            "{p}"
        );
        assert!(
            p.contains("12 mm behind") && p.contains("set G55 X and Y"),
            "{p}"
        );
        let edge = Probe::Edge {
            side: Side::YMinus,
            approach: a,
            feed: 100.0,
            retract: 2.0,
        };
        let p = edge.plan("G54", g30);
        assert!(
            p.contains("probing Y- (the back face)") && p.contains("work Y0"),
            "{p}"
        );
        let tool = Probe::ToolLength {
            tool: 3,
            setter_z: -20.0,
            distance: 30.0,
            feed: 100.0,
            retract: 2.0,
        };
        let p = tool.plan("G54", g30);
        assert!(p.contains("machine X 385.000 Y 25.000 Z 20.000"), "{p}");
        assert!(p.contains("G10 L1 P3, then G43 H3"), "{p}");
    }

    #[test]
    fn sides_and_corners_are_read_by_name() {
        assert_eq!(Side::parse("x-"), Some(Side::XMinus));
        assert_eq!(Side::parse("z+"), None);
        assert_eq!(
            Corner::parse("front-right").map(Corner::sides),
            Some([Side::XMinus, Side::YPlus])
        );
        assert_eq!(Corner::parse("middle"), None);
    }
}
