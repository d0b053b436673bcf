//! G codes by name. A block stores a G number ×10 as a `u16` (`G59.1` is 591, `G0` is 0), so
//! `G28.1` and `G28` stay apart without floats; these constants name them where the interpreter
//! and the block parser decide on one.

/// `G0` rapid.
pub(crate) const G0: u16 = 0;
/// `G1` linear feed.
pub const G1: u16 = 10;
/// `G2` clockwise arc.
pub(crate) const G2: u16 = 20;
/// `G3` counter-clockwise arc.
pub(crate) const G3: u16 = 30;
/// `G5` cubic spline (LinuxCNC).
pub(crate) const G5: u16 = 50;
/// `G5.1` quadratic spline (LinuxCNC).
pub(crate) const G5_1: u16 = 51;
/// `G4` dwell.
pub(crate) const G4: u16 = 40;
/// `G10` offsets and tool table.
pub(crate) const G10: u16 = 100;
/// `G15` polar coordinates off (Fanuc).
pub(crate) const G15: u16 = 150;
/// `G16` polar coordinates: first plane axis radius, second angle (Fanuc).
pub(crate) const G16: u16 = 160;
/// `G17` XY plane.
pub(crate) const G17: u16 = 170;
/// `G18` ZX plane.
pub(crate) const G18: u16 = 180;
/// `G19` YZ plane.
pub(crate) const G19: u16 = 190;
/// `G20` inches.
pub const G20: u16 = 200;
/// `G21` millimetres.
pub const G21: u16 = 210;
/// `G28` go to the G28 position.
pub(crate) const G28: u16 = 280;
/// `G28.1` store the G28 position.
pub(crate) const G28_1: u16 = 281;
/// `G30` go to the G30 position.
pub(crate) const G30: u16 = 300;
/// `G30.1` store the G30 position.
pub(crate) const G30_1: u16 = 301;
/// `G38.2` probe toward the workpiece, alarm without contact.
pub(crate) const G38_2: u16 = 382;
/// `G38.3` probe toward the workpiece, no alarm without contact.
pub(crate) const G38_3: u16 = 383;
/// `G38.4` probe away from the workpiece, alarm without loss of contact.
pub(crate) const G38_4: u16 = 384;
/// `G38.5` probe away from the workpiece, no alarm without loss of contact.
pub(crate) const G38_5: u16 = 385;
/// `G40` cutter compensation off.
pub(crate) const G40: u16 = 400;
/// `G41` cutter compensation left.
pub(crate) const G41: u16 = 410;
/// `G42` cutter compensation right.
pub(crate) const G42: u16 = 420;
/// `G41.1` cutter compensation left, diameter in the block.
pub(crate) const G41_1: u16 = 411;
/// `G42.1` cutter compensation right, diameter in the block.
pub(crate) const G42_1: u16 = 421;
/// `G43` tool length offset from the table.
pub(crate) const G43: u16 = 430;
/// `G43.1` dynamic tool length offset.
pub(crate) const G43_1: u16 = 431;
/// `G49` tool length offset off.
pub(crate) const G49: u16 = 490;
/// `G50` scaling off (Fanuc).
pub(crate) const G50: u16 = 500;
/// `G50.1` programmable mirror off (Fanuc).
pub(crate) const G50_1: u16 = 501;
/// `G51` scaling on (Fanuc).
pub(crate) const G51: u16 = 510;
/// `G51.1` programmable mirror on (Fanuc).
pub(crate) const G51_1: u16 = 511;
/// `G52` local offset.
pub(crate) const G52: u16 = 520;
/// `G53` machine coordinates for this block.
pub(crate) const G53: u16 = 530;
/// `G54` first work system (`G54`..`G59` are 540..590, then `G59.1`..`G59.3`).
pub const G54: u16 = 540;
/// `G55` second work system.
pub const G55: u16 = 550;
/// `G56` third work system.
pub const G56: u16 = 560;
/// `G57` fourth work system.
pub const G57: u16 = 570;
/// `G58` fifth work system.
pub const G58: u16 = 580;
/// `G59` sixth work system.
pub const G59: u16 = 590;
/// `G59.1` seventh work system.
pub(crate) const G59_1: u16 = 591;
/// `G59.2` eighth work system.
pub(crate) const G59_2: u16 = 592;
/// `G59.3` ninth work system.
pub(crate) const G59_3: u16 = 593;
/// `G61` exact path.
pub(crate) const G61: u16 = 610;
/// `G61.1` exact stop.
pub(crate) const G61_1: u16 = 611;
/// `G64` blending with a tolerance.
pub(crate) const G64: u16 = 640;
/// `G65` Fanuc macro call.
pub(crate) const G65: u16 = 650;
/// `G68` coordinate rotation (Fanuc).
pub const G68: u16 = 680;
/// `G69` coordinate rotation off (Fanuc).
pub(crate) const G69: u16 = 690;
/// `G73` peck drilling with chip break.
pub(crate) const G73: u16 = 730;
/// `G74` left-hand tapping (Fanuc).
pub(crate) const G74: u16 = 740;
/// `G76` fine boring (Fanuc).
pub(crate) const G76: u16 = 760;
/// `G80` cancel the canned cycle.
pub(crate) const G80: u16 = 800;
/// `G81` drilling.
pub(crate) const G81: u16 = 810;
/// `G82` drilling with dwell.
pub(crate) const G82: u16 = 820;
/// `G83` peck drilling.
pub(crate) const G83: u16 = 830;
/// `G84` tapping.
pub(crate) const G84: u16 = 840;
/// `G84.2` rigid tapping, right hand (Fanuc).
pub(crate) const G84_2: u16 = 842;
/// `G84.3` rigid tapping, left hand (Fanuc).
pub(crate) const G84_3: u16 = 843;
/// `G85` boring, feed out.
pub(crate) const G85: u16 = 850;
/// `G86` boring, spindle stop, rapid out.
pub(crate) const G86: u16 = 860;
/// `G87` back boring (the gixa dialect: peck with chip break).
pub(crate) const G87: u16 = 870;
/// `G88` boring, manual retract (the gixa dialect: punch).
pub(crate) const G88: u16 = 880;
/// `G89` boring with dwell, feed out.
pub(crate) const G89: u16 = 890;
/// `G90` absolute distances.
pub(crate) const G90: u16 = 900;
/// `G90.1` absolute arc centres.
pub(crate) const G90_1: u16 = 901;
/// `G91` incremental distances.
pub(crate) const G91: u16 = 910;
/// `G91.1` incremental arc centres.
pub(crate) const G91_1: u16 = 911;
/// `G92` set the G92 offset.
pub(crate) const G92: u16 = 920;
/// `G92.1` clear the G92 offset and its stored copy.
pub(crate) const G92_1: u16 = 921;
/// `G92.2` clear the G92 offset, keep the stored copy.
pub(crate) const G92_2: u16 = 922;
/// `G92.3` restore the stored G92 offset.
pub(crate) const G92_3: u16 = 923;
/// `G93` inverse time feed.
pub(crate) const G93: u16 = 930;
/// `G94` units per minute feed.
pub(crate) const G94: u16 = 940;
/// `G98` retract to the initial level.
pub(crate) const G98: u16 = 980;
/// `G99` retract to R.
pub(crate) const G99: u16 = 990;
