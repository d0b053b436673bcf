#!/usr/bin/env python3
"""A lower bound of any jerk-limited plan's time, for the moves that start and end at rest.

usage: scripts/jerk_bound.py TRAPEZOID.jsonl JERK.jsonl NAME   (`gantry simulate --json` of one
program with `jerk = 0` and with `jerk = J` on every axis, J/A = 25 s^-1 as 5,000 mm/s^3 at
200 mm/s^2; docs/motion.md, Measured)

A move the jerk-limited plan starts and ends at rest (an exact stop, G61, a reversal) cannot take
less than its time-optimal rest-to-rest profile at its path limits (A_p as the trapezoid reports
it, J_p = A_p * J/A): v/A + A/J of ramps at cruise v >= A^2/J, 2*sqrt(v/J) below, the peak speed
found by halving when the move is too short to cruise. Its length comes from the trapezoid's
time, cruise and start speed. Every other move counts at the trapezoid's time, so the bound is
weak where few moves stop.
"""
import json
import math
import sys

t=[json.loads(l) for l in open(sys.argv[1]) if '"line"' in l]
j=[json.loads(l) for l in open(sys.argv[2]) if '"line"' in l]
RATIO=25.0
tt=sum(a['time'] for a in t); tj=sum(b['time'] for b in j)
bound=0; cover=0; tj_cov=0; tt_cov=0
for a,b in zip(t,j):
    A=a['accel']; Jp=A*RATIO; v=a['cruise']/60.0; u=a['entry']/60.0
    if a['entry']!=a['exit'] or b['entry']!=0 or b['exit']!=0 or v<=0 or A is None:
        bound+=a['time']; continue
    # trapezoid from u to v and back to u: t = d/v + (v-u)^2/(A v) when v is reached
    d=v*(a['time']-(v-u)**2/(A*v))
    vpk=math.sqrt(u*u + A*d) # triangle peak if cruise not reached
    if vpk < v:
        # triangle: t = 2 (vpk-u)/A ; d = (vpk^2-u^2)/A
        d=(a['time']*A/2+u)**2/A - u*u/A; v=a['time']*A/2+u
    ramp = 2*math.sqrt(v/Jp) if v < A*A/Jp else v/A+A/Jp
    if d >= v*ramp: opt=d/v+ramp
    else:
        # no cruise: peak vp with the rest-to-rest distance d
        lo,hi=0.0,v
        for _ in range(60):
            m=(lo+hi)/2
            r = 2*math.sqrt(m/Jp) if m < A*A/Jp else m/A+A/Jp
            if m*r < d: lo=m
            else: hi=m
        r = 2*math.sqrt(lo/Jp) if lo < A*A/Jp else lo/A+A/Jp
        opt=2*r
    bound+=max(opt,a['time']); cover+=1; tj_cov+=b['time']; tt_cov+=a['time']
print(f"{sys.argv[3]}: trapezoid {tt:.2f} s, jerk {tj:.2f} s ({tj/tt:.4f}x); rest-to-rest moves {cover}/{len(t)}: trapezoid {tt_cov:.2f} s, tracker {tj_cov:.2f} s; lower bound {bound:.2f} s ({bound/tt:.4f}x)")
