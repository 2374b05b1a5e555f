//! A character ready to draw: its rig, texture and backdrop, built once and drawn on every frame.

use super::{draw_mesh, Texture};
use crate::character::{Backdrop, Character};
use crate::deform::{DeformOptions, Rig};
use crate::error::{Error, Result};
use crate::geom::Point;
use image::RgbaImage;

/// Everything needed to draw frames of one character: its rig, texture and backdrop.
pub struct Renderer {
    pub rig: Rig,
    pub texture: Texture,
    /// The frame before the character is drawn (output size).
    pub backdrop: RgbaImage,
}

impl Renderer {
    /// Builds the rig of `character` at `scale` output px per image px over a
    /// `width × height` backdrop. Errors name the character file.
    pub fn new(
        character: &Character,
        scale: f64,
        width: u32,
        height: u32,
        deform: DeformOptions,
    ) -> Result<Renderer> {
        let err = |msg: String| Error::Character {
            path: character.path.clone(),
            line: None,
            joint: None,
            msg,
        };
        let backdrop = match &character.backdrop {
            Backdrop::Colour([r, g, b]) => {
                RgbaImage::from_pixel(width, height, image::Rgba([*r, *g, *b, 255]))
            }
            Backdrop::Transparent => RgbaImage::new(width, height),
            Backdrop::Plate(p) => {
                let img = image::open(p)
                    .map_err(|e| err(format!("`background` image {}: {e}", p.display())))?
                    .to_rgb8();
                if img.dimensions() != (width, height) {
                    return Err(err(format!(
                        "`background` image {} is {}×{} px but the run's frames are \
                         {width}×{height}; give a frame-sized plate",
                        p.display(),
                        img.width(),
                        img.height()
                    )));
                }
                image::DynamicImage::ImageRgb8(img).to_rgba8()
            }
        };
        let rig = Rig::for_character(character, scale as f32, deform)
            .map_err(|m| err(format!("image {}: {m}", character.image_path.display())))?;
        Ok(Renderer {
            rig,
            texture: Texture::new(&character.image),
            backdrop,
        })
    }

    /// One frame with the character's joints at `joints` (output px).
    pub fn frame(&self, joints: &[Point]) -> RgbaImage {
        self.draw(&self.rig.deform(joints))
    }

    /// [`Renderer::frame`] and the folds and cracks of its mesh ([`Rig::defects`]).
    pub fn frame_checked(&self, joints: &[Point]) -> (RgbaImage, crate::deform::check::Defects) {
        let pos = self.rig.deform(joints);
        (self.draw(&pos), self.rig.defects(&pos))
    }

    /// The mesh at vertices `pos` drawn over the backdrop.
    fn draw(&self, pos: &[Point]) -> RgbaImage {
        let mut frame = self.backdrop.clone();
        // The seam fillers first, beneath every part (docs/method.md §5.4).
        let under: Vec<u32> = (0..self.rig.fill.len() as u32).collect();
        draw_mesh(
            &mut frame,
            pos,
            &self.rig.mesh.rest,
            &self.rig.fill,
            &under,
            &self.texture,
        );
        draw_mesh(
            &mut frame,
            pos,
            &self.rig.mesh.rest,
            &self.rig.mesh.triangles,
            &self.rig.draw_order,
            &self.texture,
        );
        frame
    }
}
