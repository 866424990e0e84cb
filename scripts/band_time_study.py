#!/usr/bin/env python3
"""How much time could a path inside the tolerance band save at the slowest spots? (dev study)

Usage (numpy + scipy only, one core is enough; not part of CI):
    python3 scripts/band_time_study.py PROGRAM.ngc SETPOINTS.csv [--tol 0.01] [--margin 0.95]
        [--feed 50] [--acc 500] [--spots 8] [--window 4.0] [--time-limit 180]

PROGRAM is the polyline (X/Y words of G0/G1 lines), SETPOINTS the current path as written by
`ncsmooth plan PROGRAM --method arc --tol 0.01 --feed 50 --acc 500 --setpoints OUT.csv`
(columns t,x,y,z,feed; fixed period, 1 ms).

What it computes. Spots are the N lowest local minima of the setpoint speed that are at least
2 mm apart. Around each spot a window of about +-WINDOW mm of path is taken, its ends snapped to
the polyline vertices nearest to those distances (so a window starts and ends near a vertex).
The current path in the window is fitted by a clamped cubic B-spline (least squares, knots every
0.04 mm within 0.45 mm of the spot, every 0.25 mm elsewhere). The control points whose Greville
abscissa lies within 0.5 mm of the spot are then moved to minimise the model traversal time plus
a quadratic penalty on (distance to polyline / (margin*tol))^2 - 1 and (vertex-to-path distance /
(margin*tol))^2 - 1 at the samples: Powell sweeps, then alternating L-BFGS-B (finite
differences) and Powell until --time-limit. The first and last 3 control points stay fixed, so
position, tangent and curvature at both window ends are those of the fit. Admissibility is
checked afterwards on 0.5 um samples: max path-to-polyline distance (segments of the window
plus 3 on each side) and max distance of every interior window vertex to the path.

Time model. Minimum-time speed profile along a fixed curve sampled at points with unit tangent
T and curvature vector K: per-axis acceleration |T_j s'' + K_j s'^2| <= ACC and s' <= FEED,
solved by the classic forward/backward pass on u = s'^2 (constant tangential acceleration
between samples, limits taken at the interval start), entry/exit speeds capped at the setpoint
speed at the window ends. Columns: `rows` = real time the setpoints spend in the window
(calibration of the model), `cur` = model on the setpoint points themselves, `fit` = model on
the B-spline fit, `opt` = model on the optimised spline (fit and opt resampled every 2 um),
`save` = cur - opt. vmin is the model's minimum speed (mm/s).

Limits. The optimiser is local (result depends on the start, knots and free set; more time
usually gives a little more; the fit itself moves by ~1-2 ms with the knot placement). The
model is not the planner: no jerk limit, no look-ahead over the rest of the program, sampled
constraints only; `rows` vs `cur` shows the gap. The fit, not
the setpoint path, is what the optimised path joins: its end tangents differ slightly
(a fraction of a degree) from the current path's, which the study ignores. Savings are per
window and assume the rest of the path is unchanged.
"""
import argparse
import re
import time

import numpy as np
from scipy.interpolate import BSpline, make_lsq_spline
from scipy.optimize import minimize

H_DENSE, HALF_DENSE, H_COARSE, FREE_HALF = 0.04, 0.45, 0.25, 0.5  # mm
SCALE, BOUND, W_PEN = 0.01, 4.0, 1e4  # control point step unit (mm), bound (units), penalty weight


def load_polyline(path):
    pts = []
    for line in open(path):
        if re.match(r"\s*G0?[01]\b", line.upper()):
            x, y = re.search(r"X([-\d.]+)", line, re.I), re.search(r"Y([-\d.]+)", line, re.I)
            if x and y:
                pts.append((float(x.group(1)), float(y.group(1))))
    return np.array(pts)


def load_setpoints(path):
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    return d[:, 0], d[:, 1:3]


def seg_dist2(q, a, b):
    """Squared distance from points q (n,2) to segments a->b (m,2), shape (n,m)."""
    ab = b - a
    t = np.clip(((q[:, None] - a[None]) * ab[None]).sum(2) / (ab ** 2).sum(1)[None], 0, 1)
    return ((q[:, None] - a[None] - t[..., None] * ab[None]) ** 2).sum(2)


def speed_caps(T, K, acc, feed):
    """Cap on u = v^2 per sample and the per-axis acceleration bounds lo_j = cl + dl*u, hi_j = ch + dh*u."""
    at = np.where(np.abs(T) < 1e-9, 1e-9, T)
    ch, dh = acc / np.abs(at), -K / at
    ucap = np.full(len(T), feed ** 2)
    for j in (0, 1):  # lower bound of one axis must stay below the upper bound of the other
        c, d = -ch[:, j] - ch[:, 1 - j], dh[:, j] - dh[:, 1 - j]
        m = d > 1e-12
        ucap[m] = np.minimum(ucap[m], -c[m] / d[m])
    return ucap, -ch, dh, ch, dh


def profile(ds, T, K, acc, feed, u0, u1):
    """Forward/backward pass; returns (time in s, speed per sample)."""
    ucap, cl, dl, ch, dh = speed_caps(T, K, acc, feed)
    u = ucap.tolist()
    u[0], u[-1] = min(u[0], u0), min(u[-1], u1)
    clx, cly, dlx, dly = cl[:, 0].tolist(), cl[:, 1].tolist(), dl[:, 0].tolist(), dl[:, 1].tolist()
    chx, chy, dhx, dhy = ch[:, 0].tolist(), ch[:, 1].tolist(), dh[:, 0].tolist(), dh[:, 1].tolist()
    dsl = ds.tolist()
    for i in range(len(u) - 1):
        un = u[i] + 2 * dsl[i] * min(chx[i] + dhx[i] * u[i], chy[i] + dhy[i] * u[i])
        if un < u[i + 1]:
            u[i + 1] = max(un, 0.0)
    for i in range(len(u) - 1, 0, -1):
        up = u[i] - 2 * dsl[i - 1] * max(clx[i] + dlx[i] * u[i], cly[i] + dly[i] * u[i])
        if up < u[i - 1]:
            u[i - 1] = max(up, 0.0)
    v = np.sqrt(np.maximum(np.array(u), 1e-12))
    return float(np.sum(2 * ds / (v[:-1] + v[1:]))), v


def geom_points(xy):
    """ds, unit tangent and curvature vector (divided differences) of dense points."""
    d = np.diff(xy, axis=0)
    xy = xy[np.r_[True, np.hypot(*d.T) > 1e-7]]
    d = np.diff(xy, axis=0)
    L = np.hypot(*d.T)
    e = d / L[:, None]
    T = np.vstack([e[0], e[:-1] * L[1:, None] + e[1:] * L[:-1, None], e[-1]])
    T /= np.hypot(*T.T)[:, None]
    K = 2 * (e[1:] - e[:-1]) / (L[:-1] + L[1:])[:, None]
    return L, T, np.vstack([K[0], K, K[-1]]), xy


def geom_spline(spl, u):
    r, d1, d2 = spl(u), spl.derivative(1)(u), spl.derivative(2)(u)
    sp = np.hypot(*d1.T)
    T = d1 / sp[:, None]
    K = (d2 - (d2 * T).sum(1)[:, None] * T) / sp[:, None] ** 2
    return np.hypot(*np.diff(r, axis=0).T), T, K, r


def find_spots(xy, v, n, sep=2.0):
    i = np.arange(1, len(v) - 1)
    mins = i[(v[i] < v[i - 1]) & (v[i] <= v[i + 1])]
    chosen = []
    for r in mins[np.argsort(v[mins])]:
        if all(np.hypot(*(xy[r] - xy[c])) >= sep for c in chosen):
            chosen.append(r)
        if len(chosen) == n:
            break
    return chosen


def window(P, xy, s, rc, half):
    """Polyline vertices k0 < k1 nearest to s[rc] -+ half along the setpoints, and their nearest rows."""
    lo, hi = np.searchsorted(s, [s[rc] - half - 1.0, s[rc] + half + 1.0])
    d2 = seg_dist2(P, xy[lo:hi - 1], xy[lo + 1:hi]).min(1)  # vertex -> path piece
    ks = np.where(d2 < 0.05 ** 2)[0]
    rows = lo + np.array([np.hypot(*(xy[lo:hi] - P[k]).T).argmin() for k in ks])
    k0 = ks[np.argmin(np.abs(s[rows] - (s[rc] - half)))]
    k1 = ks[np.argmin(np.abs(s[rows] - (s[rc] + half)))]
    return k0, k1, rows[list(ks).index(k0)], rows[list(ks).index(k1)]


class Window:
    def __init__(self, P, xy, k0, k1, sc_xy, tol_m):
        d = np.diff(xy, axis=0)
        xy = xy[np.r_[True, np.hypot(*d.T) > 1e-7]]
        s = np.r_[0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]
        S, sc = s[-1], s[np.hypot(*(xy - sc_xy).T).argmin()]
        a, b = max(sc - HALF_DENSE, 0.3), min(sc + HALF_DENSE, S - 0.3)
        kin = np.r_[np.arange(a, 0, -H_COARSE)[::-1][:-1], np.arange(a, b, H_DENSE),
                    np.arange(b, S, H_COARSE)[:-1]]
        kin = np.unique(np.round(kin[(kin > 0.05) & (kin < S - 0.05)], 9))
        self.t = np.r_[[0.0] * 4, kin, [S] * 4]
        w = np.ones(len(s))
        w[0] = w[-1] = 1e4
        self.c0 = make_lsq_spline(s, xy, self.t, k=3, w=w).c.copy()
        dense = np.arange(a - 0.2, b + 0.2, 0.002)
        self.u = np.unique(np.r_[np.linspace(0, S, int(S / 0.01) + 1), dense[(dense > 0) & (dense < S)]])
        grev = np.array([self.t[i + 1:i + 4].mean() for i in range(len(self.c0))])
        free = np.where(np.abs(grev - sc) < FREE_HALF)[0]
        self.free = free[(free >= 3) & (free <= len(self.c0) - 4)]
        self.seg_a, self.seg_b = P[k0 - 3:k1 + 3], P[k0 - 2:k1 + 4]
        self.vtx, self.S, self.tol_m = P[k0 + 1:k1], S, tol_m

    def spline(self, z):
        c = self.c0.copy()
        c[self.free] += SCALE * z.reshape(-1, 2)
        return BSpline(self.t, c, 3)

    def penalty(self, r):
        b = seg_dist2(r, self.seg_a, self.seg_b).min(1) / self.tol_m ** 2 - 1
        v = seg_dist2(self.vtx, r[:-1], r[1:]).min(1) / self.tol_m ** 2 - 1
        return np.sum(np.maximum(b, 0) ** 2) + np.sum(np.maximum(v, 0) ** 2)

    def check(self, spl):
        rr = spl(np.linspace(0, self.S, int(self.S / 0.0005) + 1))
        band = np.sqrt(seg_dist2(rr, self.seg_a, self.seg_b).min(1).max())
        return band, np.sqrt(seg_dist2(self.vtx, rr[:-1], rr[1:]).min(1).max())


def optimise(win, tmodel, time_limit):
    def f(z):
        ds, T, K, r = geom_spline(win.spline(z), win.u)
        return tmodel(ds, T, K)[0] * 1e3 + W_PEN * win.penalty(r)

    n, tic = 2 * len(win.free), time.time()
    bounds = [(-BOUND, BOUND)] * n
    z, best = np.zeros(n), f(np.zeros(n))
    for _ in range(6):  # coarse Powell sweeps (study: opt2)
        if time.time() - tic > 0.3 * time_limit:
            break
        z = minimize(f, z, method="Powell", bounds=bounds, options={"maxiter": 1, "xtol": 1e-3, "ftol": 1e-6}).x
    while time.time() - tic < time_limit:  # polish (study: opt5)
        z = minimize(f, z, method="L-BFGS-B", bounds=bounds, options={"maxiter": 100, "eps": 1e-4}).x
        z = minimize(f, z, method="Powell", bounds=bounds, options={"maxiter": 2, "xtol": 1e-3, "ftol": 1e-7}).x
        if best - f(z) < 1e-3:
            break
        best = f(z)
    return win.spline(z)


def study_spot(P, ts, xy, s, v, rc, a):
    k0, k1, r0, r1 = window(P, xy, s, rc, a.window)
    u0, u1 = v[r0] ** 2, v[r1] ** 2
    tmodel = lambda ds, T, K: profile(ds, T, K, a.acc, a.feed, u0, u1)
    t_cur, v_cur = tmodel(*geom_points(xy[r0:r1 + 1])[:3])
    win = Window(P, xy[r0:r1 + 1], k0, k1, xy[rc], a.margin * a.tol)
    fine = np.linspace(0, win.S, int(win.S / 0.002) + 1)
    t_fit = tmodel(*geom_spline(win.spline(np.zeros(2 * len(win.free))), fine)[:3])[0]
    spl = optimise(win, tmodel, a.time_limit)
    t_opt, v_opt = tmodel(*geom_spline(spl, fine)[:3])
    band, vd = win.check(spl)
    ok = "ok" if max(band, vd) <= win.tol_m + 5e-5 else ("<tol" if max(band, vd) <= a.tol else "VIOLATES")
    print(f"{xy[rc][0]:7.2f} {xy[rc][1]:6.2f}  v{k0}-{k1:<4d} {(ts[r1] - ts[r0]) * 1e3:5.0f} {t_cur * 1e3:8.2f}"
          f" {t_fit * 1e3:8.2f} {t_opt * 1e3:8.2f} {(t_cur - t_opt) * 1e3:6.2f}  {v_cur.min():5.2f}->{v_opt.min():5.2f}"
          f"  {band * 1e3:5.2f} {vd * 1e3:5.2f} {ok}", flush=True)
    return t_cur - t_opt


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("program")
    p.add_argument("setpoints")
    p.add_argument("--tol", type=float, default=0.01)
    p.add_argument("--margin", type=float, default=0.95)
    p.add_argument("--feed", type=float, default=50.0)
    p.add_argument("--acc", type=float, default=500.0)
    p.add_argument("--spots", type=int, default=8)
    p.add_argument("--window", type=float, default=4.0)
    p.add_argument("--time-limit", type=float, default=180.0)
    a = p.parse_args()
    P = load_polyline(a.program)
    ts, xy = load_setpoints(a.setpoints)
    v = np.hypot(*np.gradient(xy, ts, axis=0).T)
    s = np.r_[0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]
    print(f"{len(P)} vertices, {len(ts)} setpoints; tol {a.tol} margin {a.margin} feed {a.feed} acc {a.acc}")
    print("      x      y  window   rows      cur      fit      opt   save  vmin cur->opt  band   vtx (um)")
    total = sum(study_spot(P, ts, xy, s, v, rc, a) for rc in find_spots(xy, v, a.spots))
    print(f"TOTAL model saving {total * 1e3:.2f} ms (cur - opt, ms above)")


if __name__ == "__main__":
    main()
