#!/usr/bin/env python3
"""Turn LinuxCNC `rs274` output into Gantry's `check --canon` JSON Lines (DESIGN.md section 7).

python3 standard library only.  Two sub-commands, both used by scripts/record-rs274.sh:

  rs274_to_canon.py inject PROGRAM.ngc  > numbered.ngc
      Copies the program with an `N<line>` word at the start of every non-blank, non-`%` line
      (after a leading `/`), replacing an N word already there.  rs274 prints the N word of the
      block that issued each canonical call, so this is how we learn the 1-based file line of
      every record.  Nothing else in the program changes.

  rs274_to_canon.py convert RAW.rs274.txt > NAME.canon.jsonl
      RAW is what record-rs274.sh captured: rs274's stdout, a line `=== stderr ===`, its stderr,
      and a line `=== exit N ===`.

How rs274 coordinates map to Gantry machine coordinates (found empirically with
linuxcnc-uspace 2.9.0~pre1, see tests/golden/rs274/README.md):

  * STRAIGHT_TRAVERSE / STRAIGHT_FEED / ARC_FEED print *program* coordinates in the length units
    in force (USE_LENGTH_UNITS), i.e. before the work offset, G92 offset and tool length offset.
  * SET_G5X_OFFSET, SET_G92_OFFSET and USE_TOOL_LENGTH_OFFSET print the offset in the length
    units in force at the moment they are printed (they are re-printed when they change, not
    when the units change).
  * So: machine_mm = prog * u + g5x_mm + g92_mm + tlo_mm (per axis), where u = 1 or 25.4 at the
    time of the motion and each offset was converted to mm with the units of its own print.
  * ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end_point, a, b, c
    [, u, v, w]): the plane is the last SELECT_PLANE; XY -> (X, Y, normal Z), XZ -> first Z,
    second X, normal Y, YZ -> first Y, second Z, normal X.  rotation < 0 is clockwise (G2),
    > 0 counter-clockwise (G3); |rotation| is the number of turns (DESIGN "turns").
  * SET_FEED_RATE is units/min in the units in force at its print (in G93 rs274 has already
    converted inverse time into units/min for the following move), converted to mm/min here.
"""
import json
import re
import sys

MM_PER_INCH = 25.4


def inject(path):
    out = []
    with open(path, newline="") as f:
        text = f.read()
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    for i, line in enumerate(lines, start=1):
        s = line.strip()
        if s == "" or s.startswith("%"):
            out.append(line)
            continue
        m = re.match(r"^(\s*/?\s*)(?:[nN]\s*\d+\s*)?", line)
        out.append(m.group(1) + "N%d " % i + line[m.end():])
    sys.stdout.write("\n".join(out) + "\n")


CALL = re.compile(r"^\s*\d+\s+(?:N(\d+)\s*|N\.\.\.\.\.\s)\s*([A-Z_0-9]+)\((.*)\)\s*$")


def num(v):
    """Round away binary noise and negative zero for the JSON text."""
    r = round(v, 7)
    if r == 0:
        r = 0.0
    if r == int(r) and abs(r) < 1e15:
        return float(int(r))
    return r


def floats(args):
    return [float(x) for x in re.split(r"[,\s]+", args.strip()) if x != ""]


def convert(path):
    with open(path) as f:
        raw = f.read()
    if "=== stderr ===" not in raw:
        sys.exit("%s: no '=== stderr ===' marker" % path)
    stdout, rest = raw.split("=== stderr ===\n", 1)
    m = re.search(r"^=== exit (\d+) ===\s*$", rest, re.M)
    if not m:
        sys.exit("%s: no '=== exit N ===' marker" % path)
    stderr = rest[: m.start()]
    code = int(m.group(1))

    u = 1.0  # mm per program unit
    g5x = [0.0, 0.0, 0.0]
    g92 = [0.0, 0.0, 0.0]
    tlo = [0.0, 0.0, 0.0]
    pos = [0.0, 0.0, 0.0]  # machine mm
    feed = 0.0
    plane = "XY"
    out = []
    inch_seen = False
    last_line = 0

    def mach(p):
        return [p[i] * u + g5x[i] + g92[i] + tlo[i] for i in range(3)]

    def rec(line, op, **kw):
        r = {"line": line, "op": op}
        r.update(kw)
        out.append(r)

    for text in stdout.splitlines():
        c = CALL.match(text)
        if not c:
            continue
        line = int(c.group(1)) if c.group(1) else last_line
        if c.group(1):
            last_line = line
        name, args = c.group(2), c.group(3)
        if name == "USE_LENGTH_UNITS":
            if "INCHES" in args:
                u = MM_PER_INCH
                inch_seen = True
            elif "MM" in args:
                u = 1.0
            else:
                sys.exit("%s: unsupported units %s" % (path, args))
        elif name == "SET_G5X_OFFSET":
            v = floats(args)
            g5x = [x * u for x in v[1:4]]
        elif name == "SET_G92_OFFSET":
            v = floats(args)
            g92 = [x * u for x in v[0:3]]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            v = floats(args)
            tlo = [x * u for x in v[0:3]]
        elif name == "SET_XY_ROTATION":
            if floats(args)[0] != 0.0:
                sys.exit("%s: XY rotation is not supported by the converter" % path)
        elif name == "SET_FEED_RATE":
            feed = floats(args)[0] * u
        elif name == "SELECT_PLANE":
            plane = {"CANON_PLANE_XY": "XY", "CANON_PLANE_XZ": "ZX", "CANON_PLANE_YZ": "YZ"}[args.strip()]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            v = floats(args)
            if any(abs(x) > 0 for x in v[3:]):
                sys.exit("%s: rotary/UVW motion is not supported by the converter" % path)
            pos = mach(v[0:3])
            if name == "STRAIGHT_TRAVERSE":
                rec(line, "rapid", to=[num(x) for x in pos])
            else:
                rec(line, "feed", to=[num(x) for x in pos], feed=num(feed))
        elif name == "ARC_FEED":
            v = floats(args)
            fe, se, fa, sa, rot, ae = v[0:6]
            rot = int(rot)
            if plane == "XY":
                end_p = [fe, se, ae]
                cen_p = [fa, sa, None]
                normal = 2
            elif plane == "ZX":
                end_p = [se, ae, fe]
                cen_p = [sa, None, fa]
                normal = 1
            else:
                end_p = [ae, fe, se]
                cen_p = [None, fa, sa]
                normal = 0
            end_m = mach(end_p)
            cen_m = [0.0, 0.0, 0.0]
            for i in range(3):
                if i == normal:
                    cen_m[i] = pos[i]
                else:
                    cen_m[i] = cen_p[i] * u + g5x[i] + g92[i] + tlo[i]
            rec(line, "arc", to=[num(x) for x in end_m], center=[num(x) for x in cen_m], plane=plane,
                dir="cw" if rot < 0 else "ccw", turns=abs(rot), feed=num(feed))
            pos = end_m
        elif name == "DWELL":
            rec(line, "dwell", seconds=num(floats(args)[0]))
        elif name == "CHANGE_TOOL":
            rec(line, "tool", tool=int(floats(args)[0]))
        elif name == "SET_SPINDLE_SPEED":
            rec(line, "spindle", speed=num(floats(args)[-1]))
        elif name == "START_SPINDLE_CLOCKWISE":
            rec(line, "spindle", dir="cw")
        elif name == "START_SPINDLE_COUNTERCLOCKWISE":
            rec(line, "spindle", dir="ccw")
        elif name == "STOP_SPINDLE_TURNING":
            rec(line, "spindle", dir="off")
        elif name in ("MIST_ON", "MIST_OFF", "FLOOD_ON", "FLOOD_OFF"):
            rec(line, "coolant", what=name.lower())
        elif name in ("PROGRAM_STOP", "OPTIONAL_PROGRAM_STOP", "PROGRAM_END", "PALLET_SHUTTLE"):
            rec(line, "mcode", what=name.lower())
        elif name in ("STRAIGHT_PROBE", "RIGID_TAP", "NURBS_FEED", "SPLINE_FEED", "STRAIGHT_PROBE",
                      "SET_G5X_OFFSET_ROTATION"):
            sys.exit("%s: canonical call %s is not supported by the converter" % (path, name))

    if code != 0:
        err = [l for l in stderr.splitlines() if l.strip() and l.strip() != "executing"]
        line = None
        message = "rs274 exit %d" % code
        if err:
            echo = re.match(r"^\s*/?\s*N(\d+)\b", err[-1])
            if echo:
                line = int(echo.group(1))
                err = err[:-1]
            if err:
                message = " ".join(x.strip() for x in err)
        if line is None:
            sys.exit("%s: rs274 failed but its error names no line: %r" % (path, stderr))
        rec(line, "error", message=message)

    sys.stdout.write(
        json.dumps({"line": 0, "op": "golden", "oracle": "linuxcnc rs274", "inch_output": inch_seen}) + "\n")
    for r in out:
        sys.stdout.write(json.dumps(r) + "\n")


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("inject", "convert"):
        sys.exit(__doc__)
    if sys.argv[1] == "inject":
        inject(sys.argv[2])
    else:
        convert(sys.argv[2])


if __name__ == "__main__":
    main()
