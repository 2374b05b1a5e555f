//! Stage two of the deformation (docs/method.md §5.6, eq. 23): a non-linear least
//! squares over the joint-area vertices only, the others staying where stage one put them.
//!
//! Free vertices are those of joint triangles (triangles whose vertices are not all on one
//! bone). The energy has three equally weighted terms:
//! - **RSI Laplacian coordinates** of free silhouette vertices: at rest,
//!   `δ_i = V_i − (V_prev + V_next)/2 = a·e + b·e⊥` with `e = V_next − V_prev`; the residual
//!   `v_i − (v_prev + v_next)/2 − a·e' − b·e'⊥` is linear and invariant to rotation and scale;
//! - **mean-value coordinates** of free interior vertices over their one-ring:
//!   `v_i − Σ_j w_j v_j`, the weights `w_j ∝ (tan(α_{j−1}/2) + tan(α_j/2)) / |V_j − V_i|`
//!   from the rest mesh;
//! - **edge lengths** of every edge touching a free vertex: `(v_i − v_j) − l_ij · d_ij`
//!   with `l_ij` the rest length and `d_ij` the edge's direction at the current iterate;
//!
//! plus a faint pull towards the stage-one position that keeps the system well posed. Holding
//! `d_ij` at the current iterate makes each step a linear least squares with a fixed matrix A:
//! `AᵀA` is factored once (Cholesky, nalgebra), and each Gauss-Newton step is one solve with a
//! new right-hand side.

use super::triangulate::Mesh;
use crate::geom::Point;
use nalgebra::{DMatrix, DVector};

/// Weight of each of the three terms (equal weights, docs/method.md eq. 23).
const TERM_WEIGHT: f64 = 1.0 / 3.0;
/// Weight of the pull towards stage one (small: it only keeps the system well posed).
const ANCHOR_WEIGHT: f64 = 0.02;
/// Iterations at most, and the largest move (px) under which the solve stops early.
const MAX_ITERATIONS: usize = 12;
const TOLERANCE_PX: f64 = 0.01;

/// One residual row: `Σ coeff · coordinate − target`.
#[derive(Debug, Clone)]
struct Row {
    /// (vertex, axis 0 = x / 1 = y, coefficient), weight included.
    entries: Vec<(u32, u8, f64)>,
    target: Target,
    weight: f64,
}

#[derive(Debug, Clone, Copy)]
enum Target {
    Zero,
    /// `rest length · direction(v_i − v_j)[axis]`.
    Edge {
        i: u32,
        j: u32,
        rest_len: f64,
        axis: u8,
    },
    /// The stage-one coordinate of `v` on `axis`.
    Anchor {
        v: u32,
        axis: u8,
    },
}

/// The precomputed stage-two system of one mesh and skinning.
#[derive(Debug, Clone)]
pub struct JointSolver {
    /// Free vertices.
    free: Vec<u32>,
    /// Vertex -> index into `free`, or `u32::MAX` for a fixed vertex.
    slot: Vec<u32>,
    rows: Vec<Row>,
    /// Cholesky factor of AᵀA; `None` when nothing is free.
    chol: Option<nalgebra::Cholesky<f64, nalgebra::Dyn>>,
}

impl JointSolver {
    /// Builds the system for `mesh` with rest positions `rest` (px, at output scale) and vertex
    /// bones `skin`.
    pub fn new(mesh: &Mesh, rest: &[Point], skin: &[u16]) -> JointSolver {
        let nv = rest.len();
        let mut free_mask = vec![false; nv];
        for t in &mesh.triangles {
            let b = t.map(|v| skin[v as usize]);
            if b[0] != b[1] || b[1] != b[2] {
                for &v in t {
                    free_mask[v as usize] = true;
                }
            }
        }
        let free: Vec<u32> = (0..nv as u32).filter(|&v| free_mask[v as usize]).collect();
        let mut slot = vec![u32::MAX; nv];
        for (k, &v) in free.iter().enumerate() {
            slot[v as usize] = k as u32;
        }
        let p = |v: u32| {
            let q = rest[v as usize];
            [q.x as f64, q.y as f64]
        };
        let neighbours = one_rings(mesh, nv);
        let mut rows = Vec::new();
        let w = TERM_WEIGHT.sqrt();
        // RSI Laplacian coordinates of free outline vertices (docs/method.md eq. 23).
        for lp in &mesh.outline {
            let n = lp.len();
            for k in 0..n {
                let (vp, vi, vn) = (lp[(k + n - 1) % n], lp[k], lp[(k + 1) % n]);
                if !free_mask[vi as usize] {
                    continue;
                }
                let (pp, pi, pn) = (p(vp), p(vi), p(vn));
                let e = [pn[0] - pp[0], pn[1] - pp[1]];
                let e2 = e[0] * e[0] + e[1] * e[1];
                if e2 < 1e-12 {
                    continue;
                }
                let d = [pi[0] - 0.5 * (pp[0] + pn[0]), pi[1] - 0.5 * (pp[1] + pn[1])];
                let a = (d[0] * e[0] + d[1] * e[1]) / e2;
                let b = (d[0] * -e[1] + d[1] * e[0]) / e2;
                rows.push(Row {
                    entries: vec![
                        (vi, 0, 1.0),
                        (vp, 0, a - 0.5),
                        (vn, 0, -0.5 - a),
                        (vn, 1, b),
                        (vp, 1, -b),
                    ],
                    target: Target::Zero,
                    weight: w,
                });
                rows.push(Row {
                    entries: vec![
                        (vi, 1, 1.0),
                        (vp, 1, a - 0.5),
                        (vn, 1, -0.5 - a),
                        (vn, 0, -b),
                        (vp, 0, b),
                    ],
                    target: Target::Zero,
                    weight: w,
                });
            }
        }
        // Mean-value coordinates of free interior vertices (docs/method.md eq. 23).
        for &vi in &free {
            if mesh.on_outline[vi as usize] {
                continue;
            }
            let Some(weights) = mean_value_weights(p(vi), &neighbours[vi as usize], &p) else {
                continue;
            };
            for axis in 0..2u8 {
                let mut entries = vec![(vi, axis, 1.0)];
                entries.extend(weights.iter().map(|&(vj, wj)| (vj, axis, -wj)));
                rows.push(Row {
                    entries,
                    target: Target::Zero,
                    weight: w,
                });
            }
        }
        // Edge lengths of every edge touching a free vertex (docs/method.md eq. 23).
        for (vi, nb) in neighbours.iter().enumerate() {
            let vi = vi as u32;
            for &vj in nb {
                if vj <= vi || !(free_mask[vi as usize] || free_mask[vj as usize]) {
                    continue;
                }
                let (a, b) = (p(vi), p(vj));
                let rest_len = (a[0] - b[0]).hypot(a[1] - b[1]);
                for axis in 0..2u8 {
                    rows.push(Row {
                        entries: vec![(vi, axis, 1.0), (vj, axis, -1.0)],
                        target: Target::Edge {
                            i: vi,
                            j: vj,
                            rest_len,
                            axis,
                        },
                        weight: w,
                    });
                }
            }
        }
        for &v in &free {
            for axis in 0..2u8 {
                rows.push(Row {
                    entries: vec![(v, axis, 1.0)],
                    target: Target::Anchor { v, axis },
                    weight: ANCHOR_WEIGHT,
                });
            }
        }
        let m = 2 * free.len();
        let chol = (m > 0).then(|| {
            let mut ata = DMatrix::<f64>::zeros(m, m);
            for r in &rows {
                let fe: Vec<(usize, f64)> = r
                    .entries
                    .iter()
                    .filter(|e| slot[e.0 as usize] != u32::MAX)
                    .map(|&(v, ax, c)| (2 * slot[v as usize] as usize + ax as usize, c * r.weight))
                    .collect();
                for &(i, ci) in &fe {
                    for &(j, cj) in &fe {
                        ata[(i, j)] += ci * cj;
                    }
                }
            }
            ata.cholesky()
                // Cannot fail: the mesh builder anchors every free vertex, so AᵀA is positive definite.
                .expect("AᵀA is positive definite: every free vertex has an anchor row")
        });
        JointSolver {
            free,
            slot,
            rows,
            chol,
        }
    }

    /// Number of free (joint-area) vertices.
    pub fn free_count(&self) -> usize {
        self.free.len()
    }

    /// Moves the free vertices of `pos` (stage-one positions in, px) to the energy's minimum.
    pub fn solve(&self, pos: &mut [Point]) {
        let Some(chol) = &self.chol else {
            return;
        };
        let stage_one: Vec<[f64; 2]> = self
            .free
            .iter()
            .map(|&v| [pos[v as usize].x as f64, pos[v as usize].y as f64])
            .collect();
        let mut cur: Vec<[f64; 2]> = pos.iter().map(|q| [q.x as f64, q.y as f64]).collect();
        let m = 2 * self.free.len();
        let mut rhs = DVector::<f64>::zeros(m);
        for _ in 0..MAX_ITERATIONS {
            rhs.fill(0.0);
            for r in &self.rows {
                let mut t = match r.target {
                    Target::Zero => 0.0,
                    Target::Edge {
                        i,
                        j,
                        rest_len,
                        axis,
                    } => {
                        let (a, b) = (cur[i as usize], cur[j as usize]);
                        let d = [a[0] - b[0], a[1] - b[1]];
                        let len = d[0].hypot(d[1]);
                        if len > 1e-9 {
                            rest_len * d[axis as usize] / len
                        } else {
                            0.0
                        }
                    }
                    Target::Anchor { v, axis } => {
                        stage_one[self.slot[v as usize] as usize][axis as usize]
                    }
                };
                for &(v, ax, c) in &r.entries {
                    if self.slot[v as usize] == u32::MAX {
                        t -= c * cur[v as usize][ax as usize];
                    }
                }
                let t = t * r.weight;
                for &(v, ax, c) in &r.entries {
                    let s = self.slot[v as usize];
                    if s != u32::MAX {
                        rhs[2 * s as usize + ax as usize] += c * r.weight * t;
                    }
                }
            }
            let x = chol.solve(&rhs);
            let mut moved: f64 = 0.0;
            for (k, &v) in self.free.iter().enumerate() {
                let q = [x[2 * k], x[2 * k + 1]];
                let c = &mut cur[v as usize];
                moved = moved.max((q[0] - c[0]).abs().max((q[1] - c[1]).abs()));
                *c = q;
            }
            if moved < TOLERANCE_PX {
                break;
            }
        }
        for &v in &self.free {
            let c = cur[v as usize];
            pos[v as usize] = Point::new(c[0] as f32, c[1] as f32);
        }
    }
}

/// Each vertex's neighbours along mesh edges, sorted by index.
fn one_rings(mesh: &Mesh, nv: usize) -> Vec<Vec<u32>> {
    let mut nb: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            nb[a as usize].push(b);
            nb[b as usize].push(a);
        }
    }
    for n in &mut nb {
        n.sort_unstable();
        n.dedup();
    }
    nb
}

/// Mean-value weights (docs/method.md §5.6, normalised to sum 1) of the vertex at `c` over its
/// neighbours `ring`, which must surround it; `None` for a degenerate ring.
fn mean_value_weights(
    c: [f64; 2],
    ring: &[u32],
    pos: &dyn Fn(u32) -> [f64; 2],
) -> Option<Vec<(u32, f64)>> {
    if ring.len() < 3 {
        return None;
    }
    let mut around: Vec<(f64, u32, [f64; 2])> = ring
        .iter()
        .map(|&v| {
            let q = pos(v);
            let d = [q[0] - c[0], q[1] - c[1]];
            (d[1].atan2(d[0]), v, d)
        })
        .collect();
    around.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let n = around.len();
    // α_k: angle at c between neighbour k and k+1.
    let alpha: Vec<f64> = (0..n)
        .map(|k| {
            let (a, b) = (around[k].0, around[(k + 1) % n].0);
            (b - a).rem_euclid(std::f64::consts::TAU)
        })
        .collect();
    if alpha
        .iter()
        .any(|&a| !(1e-6..std::f64::consts::PI - 1e-6).contains(&a))
    {
        return None;
    }
    let mut w: Vec<(u32, f64)> = (0..n)
        .map(|k| {
            let d = around[k].2;
            let r = d[0].hypot(d[1]);
            (
                (alpha[(k + n - 1) % n] / 2.0).tan() + (alpha[k] / 2.0).tan(),
                r,
            )
        })
        .zip(&around)
        .map(|((t, r), a)| (a.1, t / r))
        .collect();
    let sum: f64 = w.iter().map(|x| x.1).sum();
    if !(sum.is_finite() && sum > 0.0) {
        return None;
    }
    for x in &mut w {
        x.1 /= sum;
    }
    Some(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_value_weights_reproduce_the_centre() {
        let ring = [[0.0, 0.0], [4.0, 1.0], [3.0, 5.0], [-1.0, 3.0]];
        let c = [1.5, 2.0];
        let w = mean_value_weights(c, &[0, 1, 2, 3], &|v| ring[v as usize]).unwrap();
        let mut s = [0.0, 0.0];
        for (v, wv) in &w {
            s[0] += wv * ring[*v as usize][0];
            s[1] += wv * ring[*v as usize][1];
        }
        assert!(
            (s[0] - c[0]).abs() < 1e-9 && (s[1] - c[1]).abs() < 1e-9,
            "{s:?}"
        );
        assert!(w.iter().all(|x| x.1 > 0.0));
    }
}
