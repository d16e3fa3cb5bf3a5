// What the layout asks of a body's kernel level set (seed 000 §2.4.2, 2.124–2.126, 2.130), in f64
// (the device's SHADER_F64): GPU twins of src/fluid/kernel_level_set.rs `outside_distance` (each
// node's side of the wall) and src/fluid/ghost_wall.rs `KernelLevelSet::ghost_wall` (each ghost
// node's wall point, with kernel_level_set.rs `velocity_at` there: `wall_velocity`), with the level set's sums (`sums`), Newton's depth (`depth`), the direction
// away from the body's mass (`mass_outward`) and the bracketed searches (`first_crossing`,
// src/fluid/bracket.rs `illinois`) written operation for operation as the CPU writes them, so that
// the two agree to round-off: a node's side, and a ghost's image stencil where its image point
// crosses a cell face, switch at a threshold, and f32 would switch some that the CPU does not.
// One thread per query, a gather over the CPU twin's bins of side r_e (CSR: bin b holds the
// bin-ordered points sorted[start[b] .. start[b + 1]], the order in which the CPU sums them).
// Lattice coordinates (cells).

struct Params {
    // bins' box (the points' bounding box grown by r_e): lower and upper corner, .w unused
    lo: vec4<f64>,
    hi: vec4<f64>,
    re: f64,
    r_min: f64,
    phi: f64,
    _pad0: f64,
    // bins per axis, .w number of points
    bins: vec4<u32>,
    // queries (points or ghosts)
    count: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
};

@group(0) @binding(0) var<uniform> P: Params;
// the points in bin order, three coordinates each
@group(0) @binding(1) var<storage, read> sorted: array<f64>;
@group(0) @binding(2) var<storage, read> bin_start: array<u32>;
// per bin the sum of its points' coordinates and their number
@group(0) @binding(3) var<storage, read> bin_sums: array<f64>;
// the particles' velocities in the same order as `sorted`, three each (c units)
@group(0) @binding(4) var<storage, read> sorted_velocities: array<f64>;
// outside_distance: the points (3 each); ghost_wall: per ghost the node (3) and the fluid node
// that makes it a ghost (3)
@group(0) @binding(5) var<storage, read> queries: array<f64>;
// outside_distance: per point the distance, or INSIDE; ghost_wall: per ghost the signed distance
// to the wall (negative inside), the outward normal (3) and the wall velocity (3): 7 each
@group(0) @binding(6) var<storage, read_write> answers: array<f64>;

// Smallest |∇L| in −L/|∇L| (kernel_level_set.rs `FLAT`).
const FLAT: f64 = 1e-6;
const NEWTON_STEPS: i32 = 8;
// ghost_wall.rs: MASS_RADIUS, SEARCH_REACH, CROSSING_TOLERANCE, NEWTON_TIE
const MASS_RADIUS: f64 = 3.0;
const SEARCH_REACH: f64 = 4.0;
const CROSSING_TOLERANCE: f64 = 1e-9;
const NEWTON_TIE: f64 = 1e-6;
// stands for +∞ as a search's cutoff: every distance compared with it is below SEARCH_REACH
const NO_CUTOFF: f64 = 1e300;
// f64::MIN_POSITIVE: a depth of 0 inside, so that the sign tells inside from outside
const MIN_POSITIVE: f64 = 2.2250738585072014e-308;
// outside_distance's answer for a point inside (L > 0): every distance outside is ≥ 0
const INSIDE: f64 = -1.0;

// sqrt(a·a) with the CPU's order of the sum (geometry.rs `norm`)
fn norm(a: vec3<f64>) -> f64 {
    return sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
}

fn cell_of(p: vec3<f64>) -> vec3<i32> {
    return vec3<i32>(floor((p - P.lo.xyz) / P.re));
}

// The 3ᴰ bins around a point's bin, clipped to the grid (bin coordinates, inclusive).
struct Window { lo: vec3<i32>, hi: vec3<i32> };

fn window(p: vec3<f64>) -> Window {
    let c = cell_of(p);
    return Window(max(c - vec3<i32>(1), vec3<i32>(0)), min(c + vec3<i32>(1), vec3<i32>(P.bins.xyz) - vec3<i32>(1)));
}

// The bin-ordered slots [x, y) of the window's row (y, z): its bins along x are contiguous
// (kernel_level_set.rs `runs`).
fn row_run(w: Window, y: i32, z: i32) -> vec2<u32> {
    let row = u32((z * i32(P.bins.y) + y) * i32(P.bins.x));
    return vec2<u32>(bin_start[row + u32(w.lo.x)], bin_start[row + u32(w.hi.x) + 1u]);
}

// L at p, with ∇L when `gradient` (else zero): kernel_level_set.rs `sums`, the 3ᴰ bins around p
// as rows along x in z then y order. With `stop_inside`, the sum so far as soon as it is positive
// after a row (every term is ≥ 0, so the whole sum would be positive too: the point is inside).
struct Level { l: f64, g: vec3<f64> };

fn sums(p: vec3<f64>, gradient: bool, stop_inside: bool) -> Level {
    var s = Level(-P.phi, vec3<f64>(0.0));
    let far = P.re * P.re * (1.0 + 1e-12);
    if (any(p < P.lo.xyz) || any(p > P.hi.xyz)) {
        return s;
    }
    let w = window(p);
    for (var z = w.lo.z; z <= w.hi.z; z = z + 1) {
        for (var y = w.lo.y; y <= w.hi.y; y = y + 1) {
            let run = row_run(w, y, z);
            for (var k = run.x; k < run.y; k = k + 1u) {
                let d = vec3<f64>(p.x - sorted[3u * k], p.y - sorted[3u * k + 1u], p.z - sorted[3u * k + 2u]);
                let r2 = d.x * d.x + d.y * d.y + d.z * d.z;
                if (r2 > far) { continue; }
                let r = sqrt(r2);
                if (r > P.re) { continue; }
                s.l = s.l + (P.re / max(r, P.r_min) - 1.0);
                if (gradient && r > P.r_min) {
                    let kk = -P.re / (r * r * r);
                    s.g = vec3<f64>(s.g.x + kk * d.x, s.g.y + kk * d.y, s.g.z + kk * d.z);
                }
            }
            if (stop_inside && s.l > 0.0) {
                return s;
            }
        }
    }
    return s;
}

// The wall velocity at p (2.130): the particles' velocities averaged with their kernel weights
// w = r_e/max(r, r_min) − 1 over those within r_e, zero where there are none
// (kernel_level_set.rs `velocity_at` over `slot_weights`: the bins around p in the order `sums`
// visits them, r measured from the particle to p).
fn wall_velocity(p: vec3<f64>) -> vec3<f64> {
    var v = vec3<f64>(0.0);
    var sum: f64 = 0.0;
    let far = P.re * P.re * (1.0 + 1e-12);
    if (any(p < P.lo.xyz) || any(p > P.hi.xyz)) {
        return v;
    }
    let w = window(p);
    for (var z = w.lo.z; z <= w.hi.z; z = z + 1) {
        for (var y = w.lo.y; y <= w.hi.y; y = y + 1) {
            let run = row_run(w, y, z);
            for (var k = run.x; k < run.y; k = k + 1u) {
                let d = vec3<f64>(sorted[3u * k] - p.x, sorted[3u * k + 1u] - p.y, sorted[3u * k + 2u] - p.z);
                let r2 = d.x * d.x + d.y * d.y + d.z * d.z;
                if (r2 > far) { continue; }
                let r = sqrt(r2);
                if (r > P.re) { continue; }
                let w = P.re / max(r, P.r_min) - 1.0;
                sum = sum + w;
                v = vec3<f64>(v.x + w * sorted_velocities[3u * k], v.y + w * sorted_velocities[3u * k + 1u], v.z + w * sorted_velocities[3u * k + 2u]);
            }
        }
    }
    if (sum > 0.0) {
        return vec3<f64>(v.x / sum, v.y / sum, v.z / sum);
    }
    return v;
}

// −g/|g|, zero where g is (ghost_wall.rs `outward`)
fn outward(g: vec3<f64>) -> vec3<f64> {
    let n = norm(g);
    if (n > 0.0) {
        return vec3<f64>(-g.x / n, -g.y / n, -g.z / n);
    }
    return vec3<f64>(0.0);
}

// Newton's distance to the zero contour, or < 0 for none (kernel_level_set.rs `depth`).
fn depth(p: vec3<f64>, at_p: Level) -> f64 {
    var x = p;
    // +∞ on the CPU: only a NaN fails the first comparison
    var last = NO_CUTOFF;
    for (var k = 0; k < NEWTON_STEPS; k = k + 1) {
        var s = at_p;
        if (k > 0) { s = sums(x, true, false); }
        let g2 = s.g.x * s.g.x + s.g.y * s.g.y + s.g.z * s.g.z;
        if (g2 < FLAT * FLAT || !(abs(s.l) < last)) {
            return -1.0;
        }
        last = abs(s.l);
        var step = vec3<f64>(-s.l * s.g.x / g2, -s.l * s.g.y / g2, -s.l * s.g.z / g2);
        let len = sqrt(step.x * step.x + step.y * step.y + step.z * step.z);
        if (len > 0.5) {
            step = vec3<f64>(step.x * 0.5 / len, step.y * 0.5 / len, step.z * 0.5 / len);
        }
        x = vec3<f64>(x.x + step.x, x.y + step.y, x.z + step.z);
        if (len < 1e-9) {
            let e = x - p;
            return sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
        }
    }
    return -1.0;
}

// The direction away from the body's mass within `radius` (kernel_level_set.rs `mass_outward`).
fn mass_outward(p: vec3<f64>, radius: f64) -> vec3<f64> {
    let c = cell_of(p);
    let k = i32(ceil(radius / P.re));
    let b = vec3<i32>(P.bins.xyz);
    let lo = max(c - vec3<i32>(k), vec3<i32>(0));
    let hi = min(c + vec3<i32>(k), b - vec3<i32>(1));
    var v = vec3<f64>(0.0);
    for (var z = lo.z; z <= hi.z; z = z + 1) {
        for (var y = lo.y; y <= hi.y; y = y + 1) {
            for (var x = lo.x; x <= hi.x; x = x + 1) {
                let bin = 4u * u32((z * b.y + y) * b.x + x);
                let n = bin_sums[bin + 3u];
                if (n == 0.0) { continue; }
                let d = vec3<f64>(p.x - bin_sums[bin] / n, p.y - bin_sums[bin + 1u] / n, p.z - bin_sums[bin + 2u] / n);
                let r = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
                if (r > 0.0 && r < radius) {
                    let t = 1.0 - r / radius;
                    let w = n * (t * t);
                    v = vec3<f64>(v.x + w * d.x, v.y + w * d.y, v.z + w * d.z);
                }
            }
        }
    }
    let len = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (len > 0.0) {
        return vec3<f64>(v.x / len, v.y / len, v.z / len);
    }
    return vec3<f64>(0.0);
}

fn level_along(p: vec3<f64>, dir: vec3<f64>, t: f64) -> f64 {
    return sums(vec3<f64>(p.x + t * dir.x, p.y + t * dir.y, p.z + t * dir.z), false, false).l;
}

// Where L first falls to 0 or below along `dir` from p (L = l_p > 0 there), bracketed by the
// Illinois variant of regula falsi; < 0 for none below `cutoff` (ghost_wall.rs `first_crossing`).
fn first_crossing(p: vec3<f64>, l_p: f64, dir: vec3<f64>, end: f64, cutoff: f64) -> f64 {
    if (0.0 >= cutoff) { return -1.0; }
    var a = 0.0lf;
    var fa = l_p;
    var b = min(end, SEARCH_REACH);
    var fb = level_along(p, dir, b);
    while (fb > 0.0) {
        if (b >= SEARCH_REACH) { return -1.0; }
        a = b;
        fa = fb;
        if (a >= cutoff) { return -1.0; }
        b = min(b + 0.5, SEARCH_REACH);
        fb = level_along(p, dir, b);
    }
    // bracket.rs `illinois`, 100 evaluations at most; kept: 1 the outer end, −1 the inner one
    var kept = 0;
    for (var i = 0; i < 100; i = i + 1) {
        var t = (a * fb - b * fa) / (fb - fa);
        if (!(t > a && t < b)) {
            t = 0.5 * (a + b);
        }
        let ft = level_along(p, dir, t);
        if (ft > 0.0) {
            a = t;
            fa = ft;
            if (kept == 1) { fb = fb * 0.5; }
            kept = 1;
        } else {
            b = t;
            fb = ft;
            if (kept == -1) { fa = fa * 0.5; }
            kept = -1;
        }
        if (b - a < CROSSING_TOLERANCE || a >= cutoff) { break; }
    }
    if (b < cutoff) { return b; }
    return -1.0;
}

// KernelLevelSet::ghost_wall: the signed distance and the normal of ghost `t`.
@compute @workgroup_size(64)
fn ghost_wall(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = gid.x + gid.y * nwg.x * 64u;
    if (t >= P.count) { return; }
    let q = 6u * t;
    let p = vec3<f64>(queries[q], queries[q + 1u], queries[q + 2u]);
    let outside = vec3<f64>(queries[q + 3u], queries[q + 4u], queries[q + 5u]);
    let at_p = sums(p, true, false);
    var d: f64;
    var n: vec3<f64>;
    if (!(at_p.l > 0.0)) {
        d = -at_p.l / max(norm(at_p.g), FLAT);
        n = outward(at_p.g);
    } else {
        // every candidate is a point of the contour: the smallest wins, Newton's unless a
        // search beats it by more than NEWTON_TIE
        var best = depth(p, at_p);
        var best_n = outward(at_p.g);
        let to = outside - p;
        let reach = norm(to);
        var dirs = array<vec3<f64>, 2>(mass_outward(p, MASS_RADIUS), vec3<f64>(to.x / reach, to.y / reach, to.z / reach));
        for (var k = 0; k < 2; k = k + 1) {
            let dir = dirs[k];
            if (all(dir == vec3<f64>(0.0))) { continue; }
            var cutoff = NO_CUTOFF;
            if (best >= 0.0) { cutoff = best - NEWTON_TIE; }
            let c = first_crossing(p, at_p.l, dir, reach, cutoff);
            if (c >= 0.0) {
                best = c;
                best_n = dir;
            }
        }
        if (best < 0.0) {
            best = at_p.l / max(norm(at_p.g), FLAT);
            best_n = outward(at_p.g);
        }
        if (best == 0.0) { best = MIN_POSITIVE; }
        d = -best;
        n = best_n;
    }
    // the wall point (fluid/level_set_queries.rs `wall_point`) and its velocity
    let v = wall_velocity(vec3<f64>(p.x - d * n.x, p.y - d * n.y, p.z - d * n.z));
    let o = 7u * t;
    answers[o] = d;
    answers[o + 1u] = n.x;
    answers[o + 2u] = n.y;
    answers[o + 3u] = n.z;
    answers[o + 4u] = v.x;
    answers[o + 5u] = v.y;
    answers[o + 6u] = v.z;
}

// KernelLevelSet::outside_distance: −L/|∇L| (|∇L| at least FLAT) at each point outside (L ≤ 0),
// INSIDE where L > 0.
@compute @workgroup_size(64)
fn outside_distance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = gid.x + gid.y * nwg.x * 64u;
    if (t >= P.count) { return; }
    let s = sums(vec3<f64>(queries[3u * t], queries[3u * t + 1u], queries[3u * t + 2u]), true, true);
    if (s.l > 0.0) {
        answers[t] = INSIDE;
    } else {
        answers[t] = -s.l / max(norm(s.g), FLAT);
    }
}
