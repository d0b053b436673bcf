"""G5/G5.1 reference for tests/golden/g5: LinuxCNC's canon-layer linearisation (its emccanon.cc NURBS_G5_FEED and biarc: the curve cut at 4 x control points parameter steps, each piece a biarc) written again in double precision. rs274 prints a spline only as NURBS_FEED(n, ...), so the arcs come from here; the end points are checked against rs274 by the moves after each spline (tests/golden/g5/README.md). Usage: python3 scripts/g5_reference.py < spec.json > expected.jsonl"""
import math, sys, json

def unit(x, y):
    h = math.hypot(x, y)
    return (x / h, y / h) if h != 0 else (x, y)

def knots(n, k):
    kv = []
    for i in range(n + k + 1):
        if i < k: kv.append(0)
        elif i <= n: kv.append(i - k + 1)
        else: kv.append(n - k + 2)
    return kv

def nmix(i, k, u, kv):
    if k == 1:
        return 1.0 if kv[i] <= u <= kv[i + 1] else 0.0
    a = kv[i + k - 1] - kv[i]
    b = kv[i + k] - kv[i + 1]
    if a == 0 and b != 0:
        return (kv[i + k] - u) * nmix(i + 1, k - 1, u, kv) / b
    if b == 0 and a != 0:
        return (u - kv[i]) * nmix(i, k - 1, u, kv) / a
    if a == 0 and b == 0:
        return 0.0
    return (u - kv[i]) * nmix(i, k - 1, u, kv) / a + (kv[i + k] - u) * nmix(i + 1, k - 1, u, kv) / b

def point(u, k, cps, kv):
    den = sum(nmix(i, k, u, kv) for i in range(len(cps)))
    x = sum(cps[i][0] * nmix(i, k, u, kv) / den for i in range(len(cps)))
    y = sum(cps[i][1] * nmix(i, k, u, kv) / den for i in range(len(cps)))
    return x, y

def tangent(u, k, cps, kv):
    n = len(cps) - 1
    umax = n - k + 2
    lo, hi = max(0.0, u - 1e-5), min(umax, u + 1e-5)
    p1, p3 = point(lo, k, cps, kv), point(hi, k, cps, kv)
    return unit((p3[0] - p1[0]) / (hi - lo), (p3[1] - p1[1]) / (hi - lo))

def arc(out, line, x0, y0, x1, y1, dx, dy, z, feed):
    x, y = x1 - x0, y1 - y0
    den = 2 * (y * dx - x * dy)
    if abs(den) > 1e-6:
        r = -(x * x + y * y) / den
        cx, cy = x0 + dy * r, y0 - dx * r
        out.append({"line": line, "op": "arc", "to": [x1, y1, z], "center": [cx, cy, z], "plane": "XY",
                    "dir": "ccw" if r < 0 else "cw", "turns": 1, "feed": feed})
    else:
        out.append({"line": line, "op": "feed", "to": [x1, y1, z], "feed": feed})

def biarc(out, line, p0x, p0y, tsx, tsy, p4x, p4y, tex, tey, z, feed):
    tsx, tsy = unit(tsx, tsy); tex, tey = unit(tex, tey)
    vx, vy = p0x - p4x, p0y - p4y
    c = vx * vx + vy * vy
    b = 2 * (vx * (tsx + tex) + vy * (tsy + tey))
    a = 2 * (tsx * tex + tsy * tey - 1)
    discr = b * b - 4 * a * c
    if discr < 0:
        raise SystemExit("no biarc (LinuxCNC makes nothing): pick another test shape")
    disq = math.sqrt(discr)
    if a == 0:
        out.append({"line": line, "op": "feed", "to": [p4x, p4y, z], "feed": feed}); return
    b1, b2 = (-b - disq) / 2 / a, (-b + disq) / 2 / a
    if b1 > 0 and b2 > 0:
        raise SystemExit("two positive roots (LinuxCNC makes nothing)")
    beta = max(b1, b2)
    if beta > 1e8:
        out.append({"line": line, "op": "feed", "to": [p4x, p4y, z], "feed": feed}); return
    alpha = beta
    p1x, p1y = p0x + alpha * tsx, p0y + alpha * tsy
    p3x, p3y = p4x - beta * tex, p4y - beta * tey
    p2x, p2y = (p1x * beta + p3x * alpha) / (alpha + beta), (p1y * beta + p3y * alpha) / (alpha + beta)
    tmx, tmy = unit(p3x - p2x, p3y - p2y)
    arc(out, line, p0x, p0y, p2x, p2y, tsx, tsy, z, feed)
    arc(out, line, p2x, p2y, p4x, p4y, tmx, tmy, z, feed)

def g5(out, line, cps, order, z, feed):
    n = len(cps) - 1
    umax = n - order + 2
    div = len(cps) * 4
    kv = knots(n, order)
    p0 = point(0, order, cps, kv); t0 = tangent(0, order, cps, kv)
    for i in range(1, div + 1):
        u = umax * i / div
        p1 = point(u, order, cps, kv); t1 = tangent(u, order, cps, kv)
        biarc(out, line, p0[0], p0[1], t0[0], t0[1], p1[0], p1[1], t1[0], t1[1], z, feed)
        p0, t0 = p1, t1

if __name__ == "__main__":
    out = []
    for spec in json.load(sys.stdin):
        if spec["op"] == "g5":
            g5(out, spec["line"], spec["cps"], spec["order"], spec["z"], spec["feed"])
        else:
            out.append(spec)
    for r in out:
        print(json.dumps(r))
