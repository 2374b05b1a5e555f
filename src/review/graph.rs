//! A thinned skeleton as a graph: end points (one neighbour) and branch points (three or more;
//! touching branch pixels form one point) joined by the pixel paths between them, and the pruning
//! of short spurs that a bumpy silhouette outline leaves on the skeleton.

use super::thin::{neighbour_pixels, neighbours, thin};
use image::{GrayImage, Luma};
use imageproc::region_labelling::{connected_components, Connectivity};
use std::collections::BTreeSet;

/// What kind of skeleton point a node is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeKind {
    /// One neighbour (or none: a lone pixel).
    End,
    /// Three or more neighbours: where parts of the skeleton meet.
    Branch,
}

/// An end or branch point of the skeleton.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// The point's pixel (for a branch, the pixel of its cluster nearest the cluster's mean).
    pub at: (u32, u32),
    pub kind: NodeKind,
    /// All pixels of the point (one for an end point).
    pub pixels: Vec<(u32, u32)>,
}

/// A path of skeleton pixels between two nodes (`a < b`, or `a == b` for a loop).
#[derive(Debug, Clone, PartialEq)]
pub struct Edge {
    pub a: usize,
    pub b: usize,
    /// The path's pixels, node pixels excluded (empty when the two nodes touch).
    pub pixels: Vec<(u32, u32)>,
}

/// The graph of a skeleton. Nodes are in raster order of their first pixel.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Graph {
    pub nodes: Vec<Node>,
    pub edges: Vec<Edge>,
}

impl Graph {
    /// Builds the graph of a one-pixel-wide skeleton (non-zero pixels).
    pub fn of(skel: &GrayImage) -> Graph {
        let (w, h) = skel.dimensions();
        let on = |x: u32, y: u32| skel.get_pixel(x, y).0[0] != 0;
        let mut ends = Vec::new();
        let mut branch = GrayImage::new(w, h);
        let mut path = GrayImage::new(w, h);
        for (x, y, p) in skel.enumerate_pixels() {
            if p.0[0] == 0 {
                continue;
            }
            match neighbours(skel, x, y) {
                0 | 1 => ends.push((x, y)),
                2 => path.put_pixel(x, y, Luma([255])),
                _ => branch.put_pixel(x, y, Luma([255])),
            }
        }
        // Node id of every node pixel.
        let mut node_of = vec![usize::MAX; (w * h) as usize];
        let idx = |x: u32, y: u32| (y * w + x) as usize;
        let mut nodes: Vec<Node> = Vec::new();
        let labels = connected_components(&branch, Connectivity::Eight, Luma([0]));
        let mut clusters: std::collections::BTreeMap<u32, Vec<(u32, u32)>> = Default::default();
        for (x, y, l) in labels.enumerate_pixels() {
            if l.0[0] != 0 {
                clusters.entry(l.0[0]).or_default().push((x, y));
            }
        }
        let mut found: Vec<(usize, Node)> = Vec::new();
        for (x, y) in ends {
            found.push((idx(x, y), node(NodeKind::End, vec![(x, y)])));
        }
        for (_, px) in clusters {
            let first = idx(px[0].0, px[0].1);
            found.push((first, node(NodeKind::Branch, px)));
        }
        found.sort_by_key(|(first, _)| *first);
        for (_, n) in found {
            for &(x, y) in &n.pixels {
                node_of[idx(x, y)] = nodes.len();
            }
            nodes.push(n);
        }

        let mut edges = Vec::new();
        // Paths: 8-connected runs of two-neighbour pixels, joined to the nodes they touch.
        let labels = connected_components(&path, Connectivity::Eight, Luma([0]));
        let mut runs: std::collections::BTreeMap<u32, Vec<(u32, u32)>> = Default::default();
        for (x, y, l) in labels.enumerate_pixels() {
            if l.0[0] != 0 {
                runs.entry(l.0[0]).or_default().push((x, y));
            }
        }
        for (_, px) in runs {
            let touched: BTreeSet<usize> = px
                .iter()
                .flat_map(|&(x, y)| neighbour_pixels(skel, x, y))
                .map(|(x, y)| node_of[idx(x, y)])
                .filter(|&n| n != usize::MAX)
                .collect();
            let t: Vec<usize> = touched.into_iter().collect();
            match t.as_slice() {
                [] => {} // a closed loop without end or branch points
                [a] => edges.push(Edge {
                    a: *a,
                    b: *a,
                    pixels: px,
                }),
                [a, rest @ ..] => {
                    for &b in rest {
                        edges.push(Edge {
                            a: *a,
                            b,
                            pixels: px.clone(),
                        });
                    }
                }
            }
        }
        // Nodes that touch directly.
        let mut direct = BTreeSet::new();
        for (a, n) in nodes.iter().enumerate() {
            for &(x, y) in &n.pixels {
                for (qx, qy) in neighbour_pixels(skel, x, y) {
                    let b = node_of[idx(qx, qy)];
                    if b != usize::MAX && b > a && on(qx, qy) {
                        direct.insert((a, b));
                    }
                }
            }
        }
        edges.extend(direct.into_iter().map(|(a, b)| Edge {
            a,
            b,
            pixels: Vec::new(),
        }));
        Graph { nodes, edges }
    }

    /// Indices of the edges at node `n` (a loop counts once).
    pub fn edges_at(&self, n: usize) -> Vec<usize> {
        (0..self.edges.len())
            .filter(|&e| self.edges[e].a == n || self.edges[e].b == n)
            .collect()
    }

    /// The node at the other end of edge `e` from `n`.
    pub fn other(&self, e: usize, n: usize) -> usize {
        let e = &self.edges[e];
        if e.a == n {
            e.b
        } else {
            e.a
        }
    }
}

fn node(kind: NodeKind, pixels: Vec<(u32, u32)>) -> Node {
    let n = pixels.len() as f32;
    let mx = pixels.iter().map(|p| p.0 as f32).sum::<f32>() / n;
    let my = pixels.iter().map(|p| p.1 as f32).sum::<f32>() / n;
    let at = *pixels
        .iter()
        .min_by(|p, q| {
            let d = |p: &(u32, u32)| (p.0 as f32 - mx).powi(2) + (p.1 as f32 - my).powi(2);
            d(p).total_cmp(&d(q))
        })
        .expect("a node has a pixel");
    Node { at, kind, pixels }
}

/// Removes spurs from `skel`: an end point whose path to a branch point is shorter than
/// `min_len(branch pixel)` px is erased with its path, and the skeleton thinned again, until no
/// such spur is left. Spurs are judged all at once per round, so the two prongs of a fork at a
/// blunt limb end both go and the limb keeps one end point. Returns the pruned skeleton.
pub fn prune(skel: &GrayImage, min_len: impl Fn((u32, u32)) -> f32) -> GrayImage {
    let mut s = skel.clone();
    loop {
        let g = Graph::of(&s);
        let mut erase: Vec<(u32, u32)> = Vec::new();
        for (i, n) in g.nodes.iter().enumerate() {
            if n.kind != NodeKind::End {
                continue;
            }
            let es = g.edges_at(i);
            let [e] = es.as_slice() else { continue };
            let other = g.other(*e, i);
            if g.nodes[other].kind != NodeKind::Branch {
                continue;
            }
            let len = g.edges[*e].pixels.len() as f32 + 1.0;
            if len < min_len(g.nodes[other].at) {
                erase.push(n.at);
                erase.extend(&g.edges[*e].pixels);
            }
        }
        if erase.is_empty() {
            return s;
        }
        for (x, y) in erase {
            s.put_pixel(x, y, Luma([0]));
        }
        s = thin(&s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn draw(w: u32, h: u32, pts: &[(u32, u32)]) -> GrayImage {
        let mut m = GrayImage::new(w, h);
        for &(x, y) in pts {
            m.put_pixel(x, y, Luma([255]));
        }
        m
    }

    #[test]
    fn t_junction_has_three_ends_one_branch() {
        // A horizontal line y = 5, x 1..=15, and a vertical one x = 8, y 6..=14.
        let mut pts: Vec<(u32, u32)> = (1..=15).map(|x| (x, 5)).collect();
        pts.extend((6..=14).map(|y| (8, y)));
        let g = Graph::of(&draw(20, 20, &pts));
        let ends = g.nodes.iter().filter(|n| n.kind == NodeKind::End).count();
        let branches: Vec<&Node> = g
            .nodes
            .iter()
            .filter(|n| n.kind == NodeKind::Branch)
            .collect();
        assert_eq!(ends, 3);
        assert_eq!(branches.len(), 1);
        assert!(branches[0].pixels.contains(&(8, 5)));
        assert_eq!(g.edges.len(), 3);
        let b = g
            .nodes
            .iter()
            .position(|n| n.kind == NodeKind::Branch)
            .unwrap();
        assert_eq!(g.edges_at(b).len(), 3);
    }

    #[test]
    fn short_spur_is_pruned_long_arm_kept() {
        // A line with a 2-px spur and a 10-px arm.
        let mut pts: Vec<(u32, u32)> = (1..=30).map(|x| (x, 10)).collect();
        pts.extend([(8, 9), (8, 8)]);
        pts.extend((11..=20).map(|y| (20, y)));
        let s = prune(&draw(32, 32, &pts), |_| 4.0);
        let g = Graph::of(&s);
        let ends: Vec<(u32, u32)> = g
            .nodes
            .iter()
            .filter(|n| n.kind == NodeKind::End)
            .map(|n| n.at)
            .collect();
        assert_eq!(ends.len(), 3, "{ends:?}");
        assert!(ends.contains(&(20, 20)));
        assert_eq!(s.get_pixel(8, 8).0[0], 0);
    }
}
