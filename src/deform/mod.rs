//! Deforming the target character (docs/method.md §5), one stage a module:
//! [`silhouette`] (marching squares on alpha) → [`triangulate`] (uniform samples, constrained
//! Delaunay) → [`skinning`] (vertices to bones without crossing the silhouette) → [`needle`]
//! (stage one: the variable-length needle model, area preservation) → [`solve`] (stage two:
//! Gauss-Newton over the joint-area vertices). [`split`] opens the mesh between parts hinged on
//! one joint (siblings), so that a limb can swing past its neighbour, and [`fill`] sews
//! zero-width strips into those cuts, drawn beneath (§5.4). [`fan`] places a hinge's joint area
//! by a one-to-one turn about the joint, and holds bends open (§5.5); [`check`] finds folds and
//! cracks (§5.8).
//!
//! A [`Rig`] is built once per character and then deforms the mesh for any pose, each frame on
//! its own (so frames can be deformed in parallel with identical results).

pub mod check;
pub mod fan;
pub mod fill;
pub mod needle;
pub mod silhouette;
pub mod skinning;
pub mod solve;
pub mod split;
pub mod triangulate;

use crate::geom::{Point, Vector};
use crate::skeleton::Skeleton;
use image::RgbaImage;
use needle::Needle;
use solve::JointSolver;
use triangulate::Mesh;

/// How to deform.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeformOptions {
    /// Needles scale by 1/s when their bone scales by s (docs/method.md eq. 22).
    pub area_preservation: bool,
    /// Run stage two (the joint-area solve) after stage one.
    pub stage_two: bool,
}

impl Default for DeformOptions {
    fn default() -> Self {
        DeformOptions {
            area_preservation: true,
            stage_two: true,
        }
    }
}

/// A character's mesh, skinning and solver, ready to deform.
#[derive(Debug, Clone)]
pub struct Rig {
    /// The mesh; `mesh.rest` is in image px and doubles as texture coordinates.
    pub mesh: Mesh,
    /// Bone of each vertex (index into `bones`).
    pub skin: Vec<u16>,
    /// Bones as `(parent, child)` joint indices.
    pub bones: Vec<(usize, usize)>,
    /// Triangle indices in drawing order: by layer (of the topmost bone among the triangle's
    /// vertices), then mesh order.
    pub draw_order: Vec<u32>,
    /// `(vertex, copy)`: the vertices the hinge split duplicated ([`split::Split::seams`]).
    pub seams: Vec<(u32, u32)>,
    /// Seam fillers ([`fill::fillers`]): triangles over `mesh.rest` drawn before (beneath) every
    /// part, spanning the cuts when the parts turn apart (docs/method.md §5.4).
    pub fill: Vec<[u32; 3]>,
    needles: Vec<Needle>,
    /// The hinges' joint-area vertices, placed by [`fan::place`] after stage one.
    fans: Vec<fan::FanVertex>,
    /// Rest joints (output px).
    rest_joints: Vec<Point>,
    /// The hinges whose bends [`fan::limit_bends`] holds open, root first.
    hinges: Vec<fan::Hinge>,
    rest_len: Vec<f32>,
    rest_dir: Vec<Vector>,
    solver: Option<JointSolver>,
    options: DeformOptions,
}

impl Rig {
    /// [`Rig::build`] for a character file's picture, rest pose, skeleton, layers and mesh size.
    pub fn for_character(
        character: &crate::character::Character,
        scale: f32,
        options: DeformOptions,
    ) -> Result<Rig, String> {
        Rig::build(
            &character.image,
            &character.rest,
            &character.skeleton,
            &character.layers,
            character.mesh_vertices,
            scale,
            options,
        )
    }

    /// Builds the rig of `image` with rest joints `rest` (image px), skeleton `skeleton`, bone
    /// layers `layers` (per joint: the bone ending there), about `mesh_vertices` vertices, drawn
    /// at `scale` output px per image px. Errors (as a message) when the image cannot be meshed
    /// or the skeleton has no bone.
    pub fn build(
        image: &RgbaImage,
        rest: &[Point],
        skeleton: &Skeleton,
        layers: &[i32],
        mesh_vertices: usize,
        scale: f32,
        options: DeformOptions,
    ) -> Result<Rig, String> {
        let bones = skeleton.bones();
        if bones.is_empty() {
            return Err("the skeleton has no bone (no joint has a parent)".into());
        }
        let mesh = triangulate::build_mesh(image, mesh_vertices)?;
        let layer_of_bone: Vec<i32> = bones.iter().map(|&(_, c)| layers[c]).collect();
        let skin = skinning::skin(&mesh, image, rest, &bones, &layer_of_bone);
        let split::Split {
            mesh,
            skin,
            seams,
            fill,
        } = split::split_hinges(&mesh, &skin, skeleton, &bones, rest);
        let rest_out: Vec<Point> = mesh
            .rest
            .iter()
            .map(|p| Point::from(p.coords * scale))
            .collect();
        let joints_out: Vec<Point> = rest.iter().map(|p| Point::from(p.coords * scale)).collect();
        let needles = needle::needles(&rest_out, &skin, &joints_out, &bones);
        let (rest_len, rest_dir) = bones
            .iter()
            .map(|&(p, c)| {
                let d = joints_out[c] - joints_out[p];
                let l = d.norm();
                (l, if l > 1e-6 { d / l } else { Vector::x() })
            })
            .unzip();
        let fans = fan::fans(
            &mesh.triangles,
            &rest_out,
            &skin,
            &bones,
            &joints_out,
            mesh.spacing_px * scale,
        );
        let hinges = fan::hinges(&fans, &bones, skeleton);
        let solver = options
            .stage_two
            .then(|| JointSolver::new(&mesh, &rest_out, &skin));
        let mut draw_order: Vec<u32> = (0..mesh.triangles.len() as u32).collect();
        let tri_layer = |t: u32| {
            mesh.triangles[t as usize]
                .iter()
                .map(|&v| layer_of_bone[skin[v as usize] as usize])
                .max()
                .unwrap_or(0)
        };
        draw_order.sort_by_key(|&t| (tri_layer(t), t));
        Ok(Rig {
            mesh,
            skin,
            bones,
            draw_order,
            seams,
            fill,
            needles,
            fans,
            hinges,
            rest_joints: joints_out,
            rest_len,
            rest_dir,
            solver,
            options,
        })
    }

    /// Number of joint-area vertices stage two moves (0 without stage two).
    pub fn joint_vertex_count(&self) -> usize {
        self.solver.as_ref().map_or(0, JointSolver::free_count)
    }

    /// The mesh's vertices (output px) for the joints at `joints` (output px).
    pub fn deform(&self, joints: &[Point]) -> Vec<Point> {
        let joints = &fan::limit_bends(&self.hinges, joints);
        let mut pos = vec![Point::origin(); self.mesh.rest.len()];
        needle::stage_one(
            &self.needles,
            joints,
            &self.bones,
            &self.rest_len,
            &self.rest_dir,
            self.options.area_preservation,
            &mut pos,
        );
        fan::place(&self.fans, &self.rest_joints, joints, &mut pos);
        if let Some(s) = &self.solver {
            // Stage two smooths the joint areas, but its edge lengths can push the inside of a
            // sharp bend over: then the fans' placement stands (docs/method.md §5.6).
            let fans = pos.clone();
            s.solve(&mut pos);
            let folded = |p: &[Point]| {
                self.mesh
                    .triangles
                    .iter()
                    .any(|&t| !(triangulate::triangle_area(p, t) > 0.0))
            };
            if folded(&pos) && !folded(&fans) {
                pos = fans;
            }
        }
        pos
    }

    /// The folded and cracked triangles of the mesh at vertices `pos` ([`check::defects`]).
    pub fn defects(&self, pos: &[Point]) -> check::Defects {
        check::defects(&self.mesh, &self.seams, &self.fill, pos)
    }

    /// Signed areas (px², positive = as at rest) of the triangles for vertices `pos`.
    pub fn triangle_areas(&self, pos: &[Point]) -> Vec<f32> {
        self.mesh
            .triangles
            .iter()
            .map(|&t| triangulate::triangle_area(pos, t))
            .collect()
    }
}
