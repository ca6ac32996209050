//! A bounding volume hierarchy over triangles for CPU ray tracing: binned-SAH build, flattened
//! nodes, iterative closest-hit and any-hit traversal, Möller–Trumbore intersection in f32.

use glam::Vec3;

/// SAH bins per axis: 16 is the usual point past which build quality stops improving.
const BINS: usize = 16;
/// Traversal keeps a fixed stack of this many entries, so the build caps its depth below it.
const STACK: usize = 64;
const MAX_DEPTH: u32 = STACK as u32 - 2;
/// Nodes with at most this many triangles are always leaves.
const MIN_LEAF: u32 = 2;
/// Nodes with more triangles than this are split even when the SAH prefers a leaf, so a badly
/// distributed mesh cannot produce a leaf that is tested linearly by every ray.
const MAX_LEAF: u32 = 8;

/// The closest intersection found by [`Bvh::closest_hit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (the distance when the direction is unit length).
    pub t: f32,
    /// Index of the triangle in the slice given to [`Bvh::new`].
    pub triangle: u32,
    /// Barycentric weight of the triangle's second vertex.
    pub u: f32,
    /// Barycentric weight of the triangle's third vertex.
    pub v: f32,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: first triangle in `tris`; interior: index of the left child (the right one follows it).
    first: u32,
    /// Triangles in a leaf; 0 marks an interior node.
    count: u32,
}

/// A triangle as the intersector wants it: one vertex and the two edges from it.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    /// Determinants below this are rays (nearly) parallel to the plane, or a degenerate triangle.
    det_eps: f32,
}

impl Tri {
    fn new([a, b, c]: [Vec3; 3]) -> Tri {
        let (e1, e2) = (b - a, c - a);
        // |det| ≤ |e1|·|e2| for a unit direction, and f32 computes it to about 1e-7 of that bound.
        Tri { v0: a, e1, e2, det_eps: 1e-7 * e1.length() * e2.length() }
    }

    /// Möller–Trumbore: `(t, u, v)` when the ray hits inside `(t_min, t_max)`.
    #[inline]
    fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det.abs() <= self.det_eps {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        (t > t_min && t < t_max).then_some((t, u, v))
    }
}

/// Intersects one triangle exactly as [`Bvh`] does: `(t, u, v)` for a hit with `t_min < t < t_max`.
///
/// Exposed so tests can check the hierarchy against a brute-force loop over the same arithmetic.
pub fn intersect_triangle(
    triangle: [Vec3; 3],
    origin: Vec3,
    dir: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    Tri::new(triangle).intersect(origin, dir, t_min, t_max)
}

/// A bounding volume hierarchy over a fixed set of triangles.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Triangles in leaf order.
    tris: Vec<Tri>,
    /// Caller's index of each triangle in `tris`.
    ids: Vec<u32>,
}

#[derive(Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    fn grow(&mut self, o: &Bounds) {
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }

    fn area(&self) -> f32 {
        let e = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

impl Bvh {
    /// Builds the hierarchy (binned surface-area heuristic). Triangles may be degenerate; they are
    /// never hit. Coordinates must be finite.
    pub fn new(triangles: &[[Vec3; 3]]) -> Bvh {
        let boxes: Vec<Bounds> =
            triangles.iter().map(|t| Bounds { min: t[0].min(t[1]).min(t[2]), max: t[0].max(t[1]).max(t[2]) }).collect();
        let centroids: Vec<Vec3> = boxes.iter().map(|b| 0.5 * (b.min + b.max)).collect();
        let mut ids: Vec<u32> = (0..triangles.len() as u32).collect();
        let mut root = Bounds::EMPTY;
        boxes.iter().for_each(|b| root.grow(b));
        let mut nodes = vec![Node { min: root.min, max: root.max, first: 0, count: ids.len() as u32 }];
        let mut work = vec![(0usize, 0u32)];
        while let Some((ni, depth)) = work.pop() {
            let Node { first, count, .. } = nodes[ni];
            if count <= MIN_LEAF || depth >= MAX_DEPTH {
                continue;
            }
            let range = first as usize..(first + count) as usize;
            let Some(split) = best_split(&ids[range.clone()], &boxes, &centroids) else { continue };
            let node_area = Bounds { min: nodes[ni].min, max: nodes[ni].max }.area();
            // Cost in units of one triangle test, with one node visit costing about as much.
            let leaf_cost = count as f32;
            let split_cost = 1.0 + split.cost / node_area.max(f32::MIN_POSITIVE);
            if split_cost >= leaf_cost && count <= MAX_LEAF {
                continue;
            }
            let ids_here = &mut ids[range];
            let mut mid = 0;
            for i in 0..ids_here.len() {
                if split.left_of(centroids[ids_here[i] as usize]) {
                    ids_here.swap(i, mid);
                    mid += 1;
                }
            }
            if mid == 0 || mid == ids_here.len() {
                continue;
            }
            let mut bl = Bounds::EMPTY;
            let mut br = Bounds::EMPTY;
            ids_here[..mid].iter().for_each(|&i| bl.grow(&boxes[i as usize]));
            ids_here[mid..].iter().for_each(|&i| br.grow(&boxes[i as usize]));
            let left = nodes.len();
            nodes.push(Node { min: bl.min, max: bl.max, first, count: mid as u32 });
            nodes.push(Node { min: br.min, max: br.max, first: first + mid as u32, count: count - mid as u32 });
            nodes[ni].first = left as u32;
            nodes[ni].count = 0;
            work.push((left, depth + 1));
            work.push((left + 1, depth + 1));
        }
        let tris = ids.iter().map(|&i| Tri::new(triangles[i as usize])).collect();
        Bvh { nodes, tris, ids }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// The nearest triangle hit by `origin + t·dir` with `t_min < t < t_max`.
    pub fn closest_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, mut t_max: f32) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let inv = dir.recip();
        let mut best = None;
        let mut stack = [(0u32, 0f32); STACK];
        let mut top = 0;
        if let Some(t) = self.slab(0, origin, inv, t_min, t_max) {
            stack[0] = (0, t);
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let (ni, entry) = stack[top];
            if entry >= t_max {
                continue;
            }
            let node = self.nodes[ni as usize];
            if node.count > 0 {
                for i in node.first as usize..(node.first + node.count) as usize {
                    if let Some((t, u, v)) = self.tris[i].intersect(origin, dir, t_min, t_max) {
                        t_max = t;
                        best = Some(Hit { t, triangle: self.ids[i], u, v });
                    }
                }
                continue;
            }
            let (l, r) = (node.first, node.first + 1);
            let tl = self.slab(l, origin, inv, t_min, t_max);
            let tr = self.slab(r, origin, inv, t_min, t_max);
            // Far child first on the stack so the near one is popped (and can shrink t_max) first.
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    let (near, far) = if a <= b { ((l, a), (r, b)) } else { ((r, b), (l, a)) };
                    stack[top] = far;
                    stack[top + 1] = near;
                    top += 2;
                }
                (Some(a), None) => {
                    stack[top] = (l, a);
                    top += 1;
                }
                (None, Some(b)) => {
                    stack[top] = (r, b);
                    top += 1;
                }
                (None, None) => {}
            }
        }
        best
    }

    /// Whether any triangle is hit with `t_min < t < t_max` (for shadow rays).
    pub fn any_hit(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let inv = dir.recip();
        let mut stack = [0u32; STACK];
        let mut top = 0;
        if self.slab(0, origin, inv, t_min, t_max).is_some() {
            top = 1;
        }
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if node.count > 0 {
                let leaf = &self.tris[node.first as usize..(node.first + node.count) as usize];
                if leaf.iter().any(|t| t.intersect(origin, dir, t_min, t_max).is_some()) {
                    return true;
                }
                continue;
            }
            for c in [node.first, node.first + 1] {
                if self.slab(c, origin, inv, t_min, t_max).is_some() {
                    stack[top] = c;
                    top += 1;
                }
            }
        }
        false
    }

    /// Entry distance of the ray into node `ni`'s box, if it overlaps `[t_min, t_max]`.
    #[inline]
    fn slab(&self, ni: u32, o: Vec3, inv: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let n = &self.nodes[ni as usize];
        let t0 = (n.min - o) * inv;
        let t1 = (n.max - o) * inv;
        // f32::min/max drop a NaN operand (0·∞ when the origin lies on a slab of a flat box), which
        // keeps that slab from rejecting the box: conservative, never a missed hit.
        let near = t0.min(t1).max_element().max(t_min);
        let far = t0.max(t1).min_element().min(t_max);
        (near <= far).then_some(near)
    }
}

/// A partition plane: centroids in bins `0..=bin` along `axis` go left.
struct Split {
    axis: usize,
    bin: usize,
    lo: f32,
    scale: f32,
    /// Σ area × count over both sides.
    cost: f32,
}

impl Split {
    fn left_of(&self, c: Vec3) -> bool {
        bin_of(c[self.axis], self.lo, self.scale) <= self.bin
    }
}

fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// The cheapest binned-SAH plane over the three axes, or `None` when every centroid coincides.
fn best_split(ids: &[u32], boxes: &[Bounds], centroids: &[Vec3]) -> Option<Split> {
    let mut cb = Bounds::EMPTY;
    ids.iter().for_each(|&i| cb.grow(&Bounds { min: centroids[i as usize], max: centroids[i as usize] }));
    let mut best: Option<Split> = None;
    for axis in 0..3 {
        let (lo, hi) = (cb.min[axis], cb.max[axis]);
        if hi <= lo {
            continue;
        }
        // Slightly under BINS/extent so the largest centroid lands in the last bin, not past it.
        let scale = BINS as f32 * (1.0 - 1e-6) / (hi - lo);
        let mut bins = [(Bounds::EMPTY, 0u32); BINS];
        for &i in ids {
            let b = &mut bins[bin_of(centroids[i as usize][axis], lo, scale)];
            b.0.grow(&boxes[i as usize]);
            b.1 += 1;
        }
        // Sweep from the right to get the right side of every plane, then from the left.
        let mut right_cost = [0f32; BINS];
        let (mut acc, mut n) = (Bounds::EMPTY, 0u32);
        for k in (1..BINS).rev() {
            acc.grow(&bins[k].0);
            n += bins[k].1;
            right_cost[k - 1] = if n > 0 { acc.area() * n as f32 } else { 0.0 };
        }
        let (mut acc, mut n) = (Bounds::EMPTY, 0u32);
        for k in 0..BINS - 1 {
            acc.grow(&bins[k].0);
            n += bins[k].1;
            if n == 0 || n as usize == ids.len() {
                continue;
            }
            let cost = acc.area() * n as f32 + right_cost[k];
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                best = Some(Split { axis, bin: k, lo, scale, cost });
            }
        }
    }
    best
}
