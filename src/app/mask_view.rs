//! The preview pane's mask views (issue 22): when a preset asks for masks
//! (`output.masks`), the pane can show the previewed frame's instance image
//! (each drone in its own colour) or, when depth maps are asked for, its depth
//! map, instead of the picture. They are the batch's own masks: the frame is
//! made by the same [`FramePipeline::make`] at the output's resolution, on a
//! latest-wins thread of its own that runs only while such a view is on.

use std::sync::Arc;

use egui::{Color32, ColorImage};
use serde::{Deserialize, Serialize};

use crate::annotate::masks::FrameMasks;
use crate::pipeline::FramePipeline;
use crate::preset::Preset;
use crate::render::{GpuContext, Renderer};

/// What the preview pane shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum PaneShows {
    /// The rendered picture (the default).
    #[default]
    Picture,
    /// The instance image: each drone's visible pixels in its own colour.
    Instances,
    /// The depth map: nearer drones brighter.
    Depth,
}

/// Which frame of which preset edit a mask picture belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaskKey {
    pub generation: u64,
    pub frame: u64,
}

pub struct MaskRequest {
    pub key: MaskKey,
    pub preset: Arc<Preset>,
}

/// A frame's masks as pictures for the pane.
pub struct MaskPicture {
    pub key: MaskKey,
    pub instances: ColorImage,
    /// When the preset asks for depth maps.
    pub depth: Option<ColorImage>,
    /// Pixels that show a drone (the instance image's non-background pixels).
    pub pixels_shown: usize,
    /// Drones with at least one pixel in the instance image.
    pub drones_shown: usize,
    /// Nearest and farthest depth shown, metres (with depth).
    pub depth_range_m: Option<(f64, f64)>,
}

pub type MaskResult = Result<MaskPicture, (MaskKey, String)>;

/// The mask thread's state: the previewed preset's pipeline and a renderer
/// holding its models (kept while an edit leaves the models alone).
pub struct MaskMaker {
    ctx: GpuContext,
    loaded: Option<(FramePipeline, Renderer)>,
}

impl MaskMaker {
    pub fn new(ctx: GpuContext) -> Self {
        Self { ctx, loaded: None }
    }

    /// Make the frame as the batch does and turn its masks into pictures.
    pub fn make(&mut self, request: &MaskRequest) -> MaskResult {
        let key = request.key;
        let preset = (*request.preset).clone();
        let pipeline = match &self.loaded {
            Some((loaded, _)) => loaded.update(preset),
            None => FramePipeline::new(preset),
        }
        .map_err(|e| (key, e.to_string()))?;
        let same_assets = self
            .loaded
            .as_ref()
            .is_some_and(|(loaded, _)| Arc::ptr_eq(loaded.assets(), pipeline.assets()));
        let mut renderer = match self.loaded.take() {
            Some((_, renderer)) if same_assets => renderer,
            _ => pipeline.renderer(&self.ctx),
        };
        let made = pipeline.make(&mut renderer, key.frame);
        self.loaded = Some((pipeline, renderer));
        let masks = made
            .map_err(|e| (key, e.to_string()))?
            .masks
            .ok_or_else(|| {
                (
                    key,
                    "the preset asks for no masks (output.masks)".to_string(),
                )
            })?;
        Ok(picture(key, &masks))
    }
}

/// A drone's colour in the instance view: hues a golden angle apart.
pub fn drone_colour(drone: u32) -> Color32 {
    let hue = (drone as f32 * 0.618_034).fract();
    egui::ecolor::Hsva::new(hue, 0.8, 1.0, 1.0).into()
}

/// The instance image (black where no drone shows) and, when the masks carry
/// depths, the depth map (grey from 255 at the nearest to 64 at the farthest
/// depth shown; black where no drone shows).
pub fn picture(key: MaskKey, masks: &FrameMasks) -> MaskPicture {
    let size = [masks.width as usize, masks.height as usize];
    let mut instances = ColorImage::filled(size, Color32::BLACK);
    let mut shown = std::collections::BTreeSet::new();
    for &(pixel, drone) in &masks.instance {
        if let Some(p) = instances.pixels.get_mut(pixel as usize) {
            *p = drone_colour(drone);
            shown.insert(drone);
        }
    }
    let with_depth = !masks.depth_m.is_empty() && masks.depth_m.len() == masks.instance.len();
    let depth_range_m = with_depth.then(|| {
        masks
            .depth_m
            .iter()
            .fold((f64::INFINITY, 0.0_f64), |(lo, hi), &d| {
                (lo.min(d), hi.max(d))
            })
    });
    let depth = depth_range_m.map(|(near, far)| {
        let mut image = ColorImage::filled(size, Color32::BLACK);
        let span = (far - near).max(1e-9);
        for (&(pixel, _), &d) in masks.instance.iter().zip(&masks.depth_m) {
            if let Some(p) = image.pixels.get_mut(pixel as usize) {
                let grey = 255.0 - 191.0 * ((d - near) / span).clamp(0.0, 1.0);
                *p = Color32::from_gray(grey.round() as u8);
            }
        }
        image
    });
    MaskPicture {
        key,
        instances,
        depth,
        pixels_shown: masks.instance.len(),
        drones_shown: shown.len(),
        depth_range_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn masks(depth: bool) -> FrameMasks {
        // 4×2 pixels: drone 0 at (0,0) and (1,0), drone 2 at (3,1).
        FrameMasks {
            width: 4,
            height: 2,
            pixels: vec![vec![0, 2], vec![], vec![7]],
            instance: vec![(0, 0), (1, 0), (7, 2)],
            depth_m: if depth {
                vec![10.0, 10.0, 30.0]
            } else {
                Vec::new()
            },
            flow: None,
        }
    }

    const KEY: MaskKey = MaskKey {
        generation: 1,
        frame: 0,
    };

    #[test]
    fn each_drone_shows_in_its_colour_where_its_pixels_are() {
        let p = picture(KEY, &masks(false));
        assert_eq!(p.instances.size, [4, 2]);
        assert_eq!(p.instances.pixels[0], drone_colour(0));
        assert_eq!(p.instances.pixels[1], drone_colour(0));
        assert_eq!(p.instances.pixels[7], drone_colour(2));
        assert_eq!(p.instances.pixels[2], Color32::BLACK);
        assert_ne!(drone_colour(0), drone_colour(2));
        assert_eq!((p.pixels_shown, p.drones_shown), (3, 2));
        assert!(p.depth.is_none() && p.depth_range_m.is_none());
    }

    #[test]
    fn nearer_drones_are_brighter_in_the_depth_map() {
        let p = picture(KEY, &masks(true));
        let depth = p.depth.expect("depth asked for");
        assert_eq!(depth.pixels[0], Color32::from_gray(255));
        assert_eq!(depth.pixels[7], Color32::from_gray(64));
        assert_eq!(depth.pixels[3], Color32::BLACK);
        assert_eq!(p.depth_range_m, Some((10.0, 30.0)));
    }
}
