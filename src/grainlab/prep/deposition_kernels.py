"""Compiled kernel of the geometric drop-and-roll deposition of spheres
(:mod:`grainlab.prep.deposition`; Numba, STYLE.md 2, 8).

Frame. The box is [0, L_x] x [0, L_y] x [0, inf): a floor z = 0 and four side walls; a sphere
of radius r has its centre p in [r, L_x - r] x [r, L_y - r] x [r, inf). A *support* of the
new sphere is a sphere k it touches (|p - c_k| = r + r_k =: rho_k), a side wall it touches
(the plane p_x = r, ...) or the floor (p_z = r). Its contact normal n_k is the unit vector
from the support to the centre: (p - c_k) / rho_k for a sphere, +-x, +-y for the walls, +z
for the floor.

Motion (steepest descent of the height under the contacts kept; Visscher & Bolsterli 1972,
Jodrey & Tory 1979). With no support the centre falls vertically. With one sphere support it
rolls down the great circle of the shell |p - c_k| = rho_k in the vertical plane through
c_k and p, to the shell's equator (n_z = 0), where it leaves the support and falls. A wall
alone carries no weight: the sphere falls along it. With two supports the centre runs down
the circle where both constraints hold (two shells, or a shell and a wall plane), toward the
circle's lowest point. On every path the first event ends the move:

- a new contact (a sphere, a wall or the floor): the support is added;
- (two supports) a support stops carrying: the weight -z is no longer a positive combination
  of the two normals. With c = n_a . n_b (constant on the circle) the multipliers of
  z = lam_a n_a + lam_b n_b are lam_a = (n_a,z - c n_b,z) / (1 - c^2), lam_b likewise; the
  support with lam <= 0 is dropped and the sphere rolls on the other;
- (one sphere support) the equator: the sphere falls;
- (two supports) the circle's lowest point: the sphere rests on two supports (the weight in
  the cone of their normals; a valley between two spheres).

Touching the floor ends the deposition of the sphere (it cannot go lower). Three supports
hold the sphere when z = sum lam_k n_k with all lam_k >= 0, i.e. when the vertical through
the centre passes inside the triangle of the three contact points p - r n_k (for equal spheres
the triangle of the support centres); otherwise the support of most negative lam is dropped
and the sphere rolls on the other two.

Every path is a line or a circle p(b) = m + s (cos b e_up + sig sin b e_side), b increasing;
each event is a root of f(b) = K + A cos b + B sin b crossing from f > 0 to f <= 0
(|p - c_k|^2 - rho_k^2 for a sphere, the signed distance for a plane, lam for a support).

Cost. Spheres are stored in a cell grid (cells of side >= 2 r_max, linked lists); a fall
reads the cells of the column under the sphere from the highest occupied layer of that
column down, stopping when no lower layer can be reached first; a roll reads the cells of its
circle's bounding box. Each placement thus touches O(1) spheres: the cost is linear in N,
counted per sphere in ``checks`` (distance evaluations).

Status per sphere (``status``): 0 rests on three supports, 1 on the floor, 2 on two supports,
3 the move limit was hit (a cycle of round-off; left where it was, without overlap), 4 the
resting position overlaps a sphere by more than the tolerance (a fault).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

FLOOR = -1
"""Support code of the floor z = 0 (the supports of sphere i are ``supports[i]``; >= 0: a
sphere; -2 .. -5: the walls x = 0, x = L_x, y = 0, y = L_y; -9: none)."""
WALL_X0, WALL_X1, WALL_Y0, WALL_Y1 = -2, -3, -4, -5
NO_SUPPORT = -9

RESTED_ON_THREE, RESTED_ON_FLOOR, RESTED_ON_TWO, UNSETTLED, OVERLAP = 0, 1, 2, 3, 4

_GRAZE = 1e-12   # relative: a fall passing a sphere closer than this grazes it
_ANGLE = 1e-10   # rad: an entering root this far behind the start is "now"
_WINDOW = 1e-6   # rad: a support just left is not hit again this close to the start (its
#                  constraint is tangent to the new path there: a double root split by round-off)


# --------------------------------------------------------------------------------------------
# Scalar geometry
# --------------------------------------------------------------------------------------------


@njit(inline="always")
def _wall_normal(code):
    """Contact normal (3 values) of a wall or the floor."""
    if code == WALL_X0:
        return 1.0, 0.0, 0.0
    if code == WALL_X1:
        return -1.0, 0.0, 0.0
    if code == WALL_Y0:
        return 0.0, 1.0, 0.0
    if code == WALL_Y1:
        return 0.0, -1.0, 0.0
    return 0.0, 0.0, 1.0


@njit(inline="always")
def _first_entering_root(k, a, b, beta0, beta_end):
    """Smallest b in [beta0, beta_end] where f = k + a cos b + b_ sin b reaches 0 while
    decreasing (an entering root up to :data:`_ANGLE` behind beta0 counts as beta0); inf if
    none."""
    r = math.hypot(a, b)
    if r <= 1e-300:
        return math.inf
    x = -k / r
    if x > 1.0:
        if x > 1.0 + 1e-12:
            return math.inf
        x = 1.0
    elif x < -1.0:
        if x < -1.0 - 1e-12:
            return math.inf
        x = -1.0
    phi = math.atan2(b, a)
    half = math.acos(x)
    best = math.inf
    for root in (phi + half, phi - half):
        # into [beta0 - eps, beta0 - eps + 2 pi)
        start = beta0 - _ANGLE
        root = start + ((root - start) % (2.0 * math.pi))
        if root > beta_end:
            continue
        if -a * math.sin(root) + b * math.cos(root) >= 0.0:
            continue
        if root < beta0:
            root = beta0
        if root < best:
            best = root
    return best


@njit(inline="always")
def _cell_index(value, width, n):
    c = math.floor(value / width)
    if c < 0:
        return 0
    if c >= n:
        return n - 1
    return c


@njit(inline="always")
def _normal_of(code, p, centres, radii, r, out):
    """Contact normal of support ``code`` at centre ``p`` into ``out`` (3,)."""
    if code >= 0:
        rho = r + radii[code]
        for d in range(3):
            out[d] = (p[d] - centres[code, d]) / rho
    else:
        out[0], out[1], out[2] = _wall_normal(code)


# --------------------------------------------------------------------------------------------
# One sphere: the moves
# --------------------------------------------------------------------------------------------


@njit(cache=True)
def _fall(p, r, exclude, centres, radii, r_max, head, nxt, top_layer, widths, shape, checks):
    """Fall from p: (height of the first contact, sphere hit or FLOOR); counts checks."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    reach = r + r_max
    ix0 = _cell_index(p[0] - reach, widths[0], nx)
    ix1 = _cell_index(p[0] + reach, widths[0], nx)
    iy0 = _cell_index(p[1] - reach, widths[1], ny)
    iy1 = _cell_index(p[1] + reach, widths[1], ny)
    top = -1
    for ix in range(ix0, ix1 + 1):
        for iy in range(iy0, iy1 + 1):
            top = max(top, top_layer[iy * nx + ix])
    top = min(top, _cell_index(p[2] + 1e-9 * r, widths[2], nz))
    best, hit = r, FLOOR
    for iz in range(top, -1, -1):
        if (iz + 1) * widths[2] + reach < best:
            break
        for iy in range(iy0, iy1 + 1):
            for ix in range(ix0, ix1 + 1):
                k = head[(iz * ny + iy) * nx + ix]
                while k >= 0:
                    if k != exclude:
                        checks[0] += 1
                        dx = p[0] - centres[k, 0]
                        dy = p[1] - centres[k, 1]
                        d2 = (r + radii[k]) ** 2
                        h2 = dx * dx + dy * dy
                        if h2 < d2 * (1.0 - _GRAZE):
                            zc = centres[k, 2] + math.sqrt(d2 - h2)
                            if zc <= p[2] + 1e-12 * r and zc > best:
                                best, hit = zc, k
                    k = nxt[k]
    return best, hit


@njit(cache=True)
def _circle_events(m, s, e_up, e_side, sig, beta0, beta_end, r, lx, ly, sup, n_sup, n_lam,
                   left, centres, radii, r_max, head, nxt, widths, shape, checks, lam_k, lam_a,
                   event):
    """First event on the arc p(b) = m + s (cos b e_up + sig sin b e_side), b in
    [beta0, beta_end]: returns b (inf: none) and writes ``event`` [kind, code]: kind 0 a new
    contact with support ``code``, kind 1 support ``code`` stops carrying (``lam_k``,
    ``lam_a`` (n_lam,): the multiplier of each of the first ``n_lam`` supports as
    K + A cos b; ``n_lam`` = 0 on a great circle, whose end is the equator)."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    best = math.inf
    event[0], event[1] = -1, NO_SUPPORT
    # spheres: the arc's bounding box, widened by the largest contact distance
    reach = r + r_max
    lo = np.empty(3, dtype=np.int64)
    hi = np.empty(3, dtype=np.int64)
    for d in range(3):
        # extent of the circle along axis d: s sqrt(e_up_d^2 + e_side_d^2)
        ext = s * math.sqrt(e_up[d] ** 2 + e_side[d] ** 2) + reach
        lo[d] = _cell_index(m[d] - ext, widths[d], shape[d])
        hi[d] = _cell_index(m[d] + ext, widths[d], shape[d])
    for iz in range(lo[2], hi[2] + 1):
        for iy in range(lo[1], hi[1] + 1):
            for ix in range(lo[0], hi[0] + 1):
                k = head[(iz * ny + iy) * nx + ix]
                while k >= 0:
                    own = False
                    for q in range(n_sup):
                        if sup[q] == k:
                            own = True
                    if not own:
                        checks[0] += 1
                        dm0 = m[0] - centres[k, 0]
                        dm1 = m[1] - centres[k, 1]
                        dm2 = m[2] - centres[k, 2]
                        d2 = (r + radii[k]) ** 2
                        if dm0 * dm0 + dm1 * dm1 + dm2 * dm2 <= (s + r + radii[k]) ** 2:
                            kk = dm0 * dm0 + dm1 * dm1 + dm2 * dm2 + s * s - d2
                            aa = 2.0 * s * (dm0 * e_up[0] + dm1 * e_up[1] + dm2 * e_up[2])
                            bb = 2.0 * s * sig * (dm0 * e_side[0] + dm1 * e_side[1]
                                                  + dm2 * e_side[2])
                            b = _first_entering_root(kk, aa, bb, beta0 + _WINDOW
                                                     if k == left else beta0, beta_end)
                            if b < best:
                                best = b
                                event[0], event[1] = 0, k
                    k = nxt[k]
    _ = nz
    # the floor and the walls: signed distance of the centre to its plane
    for code in (FLOOR, WALL_X0, WALL_X1, WALL_Y0, WALL_Y1):
        own = False
        for q in range(n_sup):
            if sup[q] == code:
                own = True
        if own:
            continue
        if code == FLOOR:
            kk, aa, bb = m[2] - r, s * e_up[2], s * sig * e_side[2]
        elif code == WALL_X0:
            kk, aa, bb = m[0] - r, s * e_up[0], s * sig * e_side[0]
        elif code == WALL_X1:
            kk, aa, bb = lx - r - m[0], -s * e_up[0], -s * sig * e_side[0]
        elif code == WALL_Y0:
            kk, aa, bb = m[1] - r, s * e_up[1], s * sig * e_side[1]
        else:
            kk, aa, bb = ly - r - m[1], -s * e_up[1], -s * sig * e_side[1]
        b = _first_entering_root(kk, aa, bb, beta0 + _WINDOW if code == left else beta0,
                                 beta_end)
        if b < best:
            best = b
            event[0], event[1] = 0, code
    # supports that stop carrying
    for q in range(n_lam):
        b = _first_entering_root(lam_k[q], lam_a[q], 0.0, beta0, beta_end)
        if b < best:
            best = b
            event[0], event[1] = 1, sup[q]
    return best


@njit(inline="always")
def _arc_point(m, s, e_up, e_side, sig, b, p):
    c, sn = math.cos(b), sig * math.sin(b)
    for d in range(3):
        p[d] = m[d] + s * (c * e_up[d] + sn * e_side[d])


@njit(inline="always")
def _plane_value(code, r, lx, ly):
    """(axis, coordinate) of the centre on the plane of wall ``code``."""
    if code == WALL_X0:
        return 0, r
    if code == WALL_X1:
        return 0, lx - r
    if code == WALL_Y0:
        return 1, r
    return 1, ly - r


@njit(inline="always")
def _two_support_circle(a, w, r, lx, ly, centres, radii, m, nc):
    """The circle where sphere support ``a`` and support ``w`` (a sphere or a wall) are both
    touched: centre into ``m``, the unit normal of its plane into ``nc``; returns its radius
    s [m]."""
    rho_a = r + radii[a]
    if w >= 0:
        rho_b = r + radii[w]
        dist = 0.0
        for d in range(3):
            nc[d] = centres[w, d] - centres[a, d]
            dist += nc[d] * nc[d]
        dist = math.sqrt(dist)
        for d in range(3):
            nc[d] /= dist
        t = (dist * dist + rho_a * rho_a - rho_b * rho_b) / (2.0 * dist)
        for d in range(3):
            m[d] = centres[a, d] + t * nc[d]
    else:
        axis, value = _plane_value(w, r, lx, ly)
        nc[0], nc[1], nc[2] = _wall_normal(w)
        for d in range(3):
            m[d] = centres[a, d]
        t = value - centres[a, axis]
        m[axis] = value
    return math.sqrt(max(rho_a * rho_a - t * t, 0.0))


@njit(inline="always")
def _slides(drop, stay, r, lx, ly, centres, radii):
    """Whether the sphere, leaving support ``drop`` (its lam reached 0) to roll on ``stay``
    alone, would at once run into ``drop`` again: the region ``drop`` excludes (its ball
    r + r_k, or the far side of its wall) cuts the shell of ``stay`` in a cap larger than a
    hemisphere, so the meridian tangent to the cap's rim runs inside it. It then slides on
    along the rim (both supports kept)."""
    if stay < 0:
        return False
    if drop >= 0:
        dist2 = 0.0
        for d in range(3):
            dist2 += (centres[drop, d] - centres[stay, d]) ** 2
        return dist2 + (r + radii[stay]) ** 2 - (r + radii[drop]) ** 2 < 0.0
    if drop == FLOOR:
        return False
    axis, value = _plane_value(drop, r, lx, ly)
    inward = 1.0 if drop == WALL_X0 or drop == WALL_Y0 else -1.0
    # the centre of stay beyond the plane (on the side the wall excludes)
    return (centres[stay, axis] - value) * inward < 0.0


@njit(cache=True)
def deposit_kernel(radii, drops, lx, ly, widths, shape, max_moves,
                   centres, supports, checks, status, head, nxt, top_layer):
    """Deposit the spheres one by one in the order given (module docstring).

    Inputs: ``radii`` (N,) [m]; ``drops`` (N, 2) uniform numbers in [0, 1) placing each drop
    in [r, L_x - r] x [r, L_y - r]; ``lx``, ``ly`` [m]; the grid's cell ``widths`` (3,) [m]
    (>= 2 r_max) and ``shape`` (3,) int; ``max_moves`` per sphere. Outputs: ``centres``
    (N, 3) [m], ``supports`` (N, 3) (codes: FLOOR, walls, sphere index, NO_SUPPORT),
    ``checks`` (N,) distance evaluations, ``status`` (N,), and the grid ``head`` (cells,),
    ``nxt`` (N,), ``top_layer`` (nx ny,) (highest occupied layer of each column, -1).
    Returns -1, or the index of the first sphere that rested above the grid (grow it).
    """
    n = radii.shape[0]
    nx, ny, nz = shape[0], shape[1], shape[2]
    r_max = 0.0
    for i in range(n):
        r_max = max(r_max, radii[i])
    for c in range(head.shape[0]):
        head[c] = -1
    for c in range(top_layer.shape[0]):
        top_layer[c] = -1
    p = np.empty(3)
    m = np.empty(3)
    e_up = np.empty(3)
    e_side = np.empty(3)
    na = np.empty(3)
    nb = np.empty(3)
    nc = np.empty(3)
    sup = np.full(3, NO_SUPPORT, dtype=np.int64)
    lam_k = np.zeros(3)
    lam_a = np.zeros(3)
    event = np.zeros(2, dtype=np.int64)
    kz = np.zeros(2)
    az = np.zeros(2)
    count = np.zeros(1, dtype=np.int64)
    for i in range(n):
        r = radii[i]
        count[0] = 0
        p[0] = r + drops[i, 0] * (lx - 2.0 * r)
        p[1] = r + drops[i, 1] * (ly - 2.0 * r)
        p[2] = nz * widths[2] + 2.0 * r_max + r
        n_sup = 0
        left = NO_SUPPORT  # the support just left: not hit again at the start of the move
        keep = NO_SUPPORT  # a support slid on although its lam < 0 (:func:`_slides`)
        state = UNSETTLED
        for _move in range(max_moves):
            if n_sup == 0:
                z, hit = _fall(p, r, np.int64(left), centres, radii, r_max, head, nxt,
                               top_layer, widths, shape, count)  # int64: one signature
                p[2] = z
                left = NO_SUPPORT
                keep = NO_SUPPORT
                sup[0] = hit
                n_sup = 1
                if hit == FLOOR:
                    state = RESTED_ON_FLOOR
                    break
                continue
            if n_sup == 1:
                a = sup[0]
                if a < 0:  # a wall alone carries nothing
                    n_sup = 0
                    continue
                rho = r + radii[a]
                for d in range(3):
                    m[d] = centres[a, d]
                hx, hy = p[0] - m[0], p[1] - m[1]
                h = math.hypot(hx, hy)
                if h <= 1e-14 * rho:
                    hx, hy, h = 1.0, 0.0, 1.0  # on the very top: roll along +x
                e_up[0], e_up[1], e_up[2] = 0.0, 0.0, 1.0
                e_side[0], e_side[1], e_side[2] = hx / h, hy / h, 0.0
                beta0 = math.atan2(h, p[2] - m[2])
                if beta0 > 0.5 * math.pi:
                    beta0 = 0.5 * math.pi
                b = _circle_events(m, rho, e_up, e_side, 1.0, beta0, 0.5 * math.pi, r, lx,
                                   ly, sup, np.int64(1), np.int64(0), np.int64(left), centres,
                                   radii, r_max, head, nxt, widths, shape, count, lam_k, lam_a,
                                   event)  # int64s, not literals: one signature
                if b == math.inf:  # the equator: fall
                    _arc_point(m, rho, e_up, e_side, 1.0, 0.5 * math.pi, p)
                    left = a
                    n_sup = 0
                    continue
                _arc_point(m, rho, e_up, e_side, 1.0, b, p)
                left = NO_SUPPORT
                sup[1] = event[1]
                n_sup = 2
                if event[1] == FLOOR:
                    state = RESTED_ON_FLOOR
                    break
                continue
            if n_sup == 2:
                # the circle of the two constraints (a sphere first)
                if sup[0] < 0:
                    sup[0], sup[1] = sup[1], sup[0]
                a, w = sup[0], sup[1]
                if a < 0:  # two walls: fall along the corner
                    left = NO_SUPPORT
                    n_sup = 0
                    continue
                s = _two_support_circle(a, w, r, lx, ly, centres, radii, m, nc)
                # the weight on the two supports
                _normal_of(a, p, centres, radii, r, na)
                _normal_of(w, p, centres, radii, r, nb)
                c = na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2]
                den = 1.0 - c * c
                if den <= 1e-14:
                    la, lb = 0.0, -1.0
                else:
                    la = (na[2] - c * nb[2]) / den
                    lb = (nb[2] - c * na[2]) / den
                if a == keep:
                    la = max(la, 1.0)
                if w == keep:
                    lb = max(lb, 1.0)
                if la <= 0.0 or lb <= 0.0:
                    drop, stay = (a, w) if la < lb else (w, a)
                    if _slides(drop, stay, r, lx, ly, centres, radii):
                        keep = drop
                        continue
                    sup[0] = stay
                    left = drop
                    n_sup = 1
                    continue
                rho_a = r + radii[a]
                gz = 1.0 - nc[2] * nc[2]
                if gz <= 1e-14 or s <= 1e-14 * rho_a:
                    state = RESTED_ON_TWO  # a horizontal circle (or a point): no way down
                    break
                g = math.sqrt(gz)
                for d in range(3):
                    e_up[d] = -nc[2] * nc[d] / g
                e_up[2] += 1.0 / g
                e_side[0] = nc[1] * e_up[2] - nc[2] * e_up[1]
                e_side[1] = nc[2] * e_up[0] - nc[0] * e_up[2]
                e_side[2] = nc[0] * e_up[1] - nc[1] * e_up[0]
                cu = (p[0] - m[0]) * e_up[0] + (p[1] - m[1]) * e_up[1] + (p[2] - m[2]) * e_up[2]
                cs = (p[0] - m[0]) * e_side[0] + (p[1] - m[1]) * e_side[1] \
                    + (p[2] - m[2]) * e_side[2]
                sig = 1.0 if cs >= 0.0 else -1.0
                beta0 = math.atan2(abs(cs), cu)
                # multipliers of the two supports as K + A cos b (n_z linear in cos b)
                for q in range(2):
                    code = sup[q]
                    kz[q], az[q] = 0.0, 0.0
                    if code >= 0:
                        rq = r + radii[code]
                        kz[q] = (m[2] - centres[code, 2]) / rq
                        az[q] = s * e_up[2] / rq
                for q in range(2):
                    lam_k[q] = kz[q] - c * kz[1 - q]
                    lam_a[q] = az[q] - c * az[1 - q]
                    if sup[q] == keep:  # sliding on it: it carries whatever lam says
                        lam_k[q], lam_a[q] = 1.0, 0.0
                b = _circle_events(m, s, e_up, e_side, sig, beta0, math.pi, r, lx, ly, sup,
                                   np.int64(2), np.int64(2), np.int64(left), centres, radii,
                                   r_max, head, nxt, widths, shape, count, lam_k, lam_a, event)
                left = NO_SUPPORT
                if b == math.inf:  # the lowest point of the circle
                    _arc_point(m, s, e_up, e_side, sig, math.pi, p)
                    state = RESTED_ON_TWO
                    break
                _arc_point(m, s, e_up, e_side, sig, b, p)
                if event[0] == 1:  # a support stops carrying
                    drop = event[1]
                    stay = sup[1] if sup[0] == drop else sup[0]
                    if _slides(drop, stay, r, lx, ly, centres, radii):
                        keep = drop
                        continue
                    sup[0] = stay
                    left = drop
                    n_sup = 1
                    continue
                sup[2] = event[1]
                keep = NO_SUPPORT
                n_sup = 3
                if event[1] == FLOOR:
                    state = RESTED_ON_FLOOR
                    break
                continue
            # three supports: z = sum lam_k n_k (Cramer's rule)
            _normal_of(sup[0], p, centres, radii, r, na)
            _normal_of(sup[1], p, centres, radii, r, nb)
            _normal_of(sup[2], p, centres, radii, r, nc)
            det = (na[0] * (nb[1] * nc[2] - nb[2] * nc[1])
                   - nb[0] * (na[1] * nc[2] - na[2] * nc[1])
                   + nc[0] * (na[1] * nb[2] - na[2] * nb[1]))
            if abs(det) <= 1e-12:  # coplanar normals: roll on the two newest
                left = sup[0]
                sup[0] = sup[2]
                n_sup = 2
                continue
            # z = (0, 0, 1): lam_q = det(columns with column q replaced by z) / det
            l0 = (nb[0] * nc[1] - nb[1] * nc[0]) / det
            l1 = (nc[0] * na[1] - nc[1] * na[0]) / det
            l2 = (na[0] * nb[1] - na[1] * nb[0]) / det
            if l0 >= 0.0 and l1 >= 0.0 and l2 >= 0.0:
                state = RESTED_ON_THREE
                break
            worst = 0
            if l1 < l0 and l1 <= l2:
                worst = 1
            elif l2 < l0 and l2 < l1:
                worst = 2
            left = sup[worst]
            sup[worst] = sup[2]
            n_sup = 2
        for d in range(3):
            centres[i, d] = p[d]
        for q in range(3):
            supports[i, q] = sup[q] if q < n_sup else NO_SUPPORT
        # a fault check: no overlap with the neighbours (not counted in checks)
        ix = _cell_index(p[0], widths[0], nx)
        iy = _cell_index(p[1], widths[1], ny)
        iz = math.floor(p[2] / widths[2])
        if iz >= nz:
            return i
        for jz in range(max(iz - 1, 0), min(iz + 2, nz)):
            for jy in range(max(iy - 1, 0), min(iy + 2, ny)):
                for jx in range(max(ix - 1, 0), min(ix + 2, nx)):
                    k = head[(jz * ny + jy) * nx + jx]
                    while k >= 0:
                        dd = 0.0
                        for d in range(3):
                            dd += (p[d] - centres[k, d]) ** 2
                        if math.sqrt(dd) < (r + radii[k]) * (1.0 - 1e-9):
                            state = OVERLAP
                        k = nxt[k]
        status[i] = state
        checks[i] = count[0]
        cell = (iz * ny + iy) * nx + ix
        nxt[i] = head[cell]
        head[cell] = i
        if iz > top_layer[iy * nx + ix]:
            top_layer[iy * nx + ix] = iz
    return -1
