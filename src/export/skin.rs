//! The target character's image as one mesh for the skeleton formats ([`SkinMesh`]): meshed,
//! skinned and split at hinges exactly as `mocap2d render` does it ([`crate::deform::Rig`]), each
//! vertex bound rigidly to one bone.
//!
//! The exported setup pose is the first retargeted frame, which differs from the character's
//! rest pose when a filter moved it; so each vertex is carried from the rest bone to the first
//! frame's bone: its offset from the bone's start, measured along the bone (as a share of the
//! bone's length) and across it (px), is laid on the first frame's bone. That is what a skeleton
//! runtime does with a bone scaled along its x axis, so the mesh shows in the setup pose as
//! `render` would draw it with stage one alone.

use super::SkinMesh;
use crate::character::Character;
use crate::deform::{DeformOptions, Rig};
use crate::error::{Error, Result};
use crate::retarget::{Placement, P64};

/// The skin of `character`, placed by `placement` (from `retarget.toml`), in the pose `first`
/// (output px, the character's joint order). Its image is named by its file name alone: the
/// exporter copies it beside the files that name it. Errors name the character file.
pub fn skin_mesh(character: &Character, placement: Placement, first: &[P64]) -> Result<SkinMesh> {
    let err = |msg: String| Error::Character {
        path: character.path.clone(),
        line: None,
        joint: None,
        msg,
    };
    let options = DeformOptions {
        area_preservation: true,
        stage_two: false,
    };
    let rig = Rig::for_character(character, placement.scale as f32, options)
        .map_err(|m| err(format!("image {}: {m}", character.image_path.display())))?;
    let mesh = &rig.mesh;
    let rest: Vec<P64> = character.rest.iter().map(|&p| placement.apply(p)).collect();

    // Vertex order: the outer outline first (Spine's `hull`), then the rest in mesh order.
    let outer = mesh
        .outline
        .iter()
        .max_by(|a, b| loop_area(mesh, a).total_cmp(&loop_area(mesh, b)))
        .cloned()
        .unwrap_or_default();
    let mut order: Vec<u32> = outer.clone();
    let mut taken = vec![false; mesh.rest.len()];
    for &v in &outer {
        taken[v as usize] = true;
    }
    order.extend((0..mesh.rest.len() as u32).filter(|&v| !taken[v as usize]));
    let mut new_index = vec![0u32; mesh.rest.len()];
    for (i, &v) in order.iter().enumerate() {
        new_index[v as usize] = i as u32;
    }

    let (iw, ih) = character.image.dimensions();
    let mut uvs = Vec::with_capacity(order.len());
    let mut posed = Vec::with_capacity(order.len());
    let mut bone = Vec::with_capacity(order.len());
    for &v in &order {
        let p = mesh.rest[v as usize];
        // Pixel centres are on integer coordinates: the image spans -0.5 .. w - 0.5.
        uvs.push([
            (p.x as f64 + 0.5) / iw as f64,
            (p.y as f64 + 0.5) / ih as f64,
        ]);
        let b = rig.skin[v as usize] as usize;
        let (pj, cj) = rig.bones[b];
        posed.push(carry(
            placement.apply(p),
            [rest[pj], rest[cj]],
            [first[pj], first[cj]],
        ));
        bone.push(b);
    }
    let triangles = rig
        .draw_order
        .iter()
        .map(|&t| mesh.triangles[t as usize].map(|v| new_index[v as usize]))
        .collect();
    let name = character
        .image_path
        .file_stem()
        .map_or("character".into(), |s| s.to_string_lossy().into_owned());
    Ok(SkinMesh {
        name,
        image: character
            .image_path
            .file_name()
            .map_or("character.png".into(), |s| s.to_string_lossy().into_owned()),
        image_width: iw,
        image_height: ih,
        uvs,
        rest: posed,
        bone,
        triangles,
        hull: outer.len(),
    })
}

/// `p` (px), bound to the bone `from` (start, end), carried onto the bone `to`: its distance
/// along the bone scales with the bone's length, its distance across it stays.
pub fn carry(p: P64, from: [P64; 2], to: [P64; 2]) -> P64 {
    let axes = |b: [P64; 2]| {
        let d = [b[1][0] - b[0][0], b[1][1] - b[0][1]];
        let l = d[0].hypot(d[1]);
        let u = if l > 1e-9 {
            [d[0] / l, d[1] / l]
        } else {
            [1.0, 0.0]
        };
        (u, l)
    };
    let ((u0, l0), (u1, l1)) = (axes(from), axes(to));
    let d = [p[0] - from[0][0], p[1] - from[0][1]];
    let along = d[0] * u0[0] + d[1] * u0[1];
    let across = -d[0] * u0[1] + d[1] * u0[0];
    let along = if l0 > 1e-9 { along * l1 / l0 } else { along };
    [
        to[0][0] + along * u1[0] - across * u1[1],
        to[0][1] + along * u1[1] + across * u1[0],
    ]
}

fn loop_area(mesh: &crate::deform::triangulate::Mesh, l: &[u32]) -> f64 {
    let pts: Vec<_> = l.iter().map(|&v| mesh.rest[v as usize]).collect();
    crate::deform::silhouette::signed_area(&pts).abs() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn carry_keeps_the_offset_across_and_scales_along() {
        // A bone along +x of length 10 turned to +y with length 20.
        let from = [[0.0, 0.0], [10.0, 0.0]];
        let to = [[5.0, 5.0], [5.0, 25.0]];
        let q = carry([5.0, 2.0], from, to);
        // Halfway along (10 of 20 px), 2 px to the bone's right (on screen: -x after the turn).
        assert!(
            (q[0] - 3.0).abs() < 1e-12 && (q[1] - 15.0).abs() < 1e-12,
            "{q:?}"
        );
    }
}
