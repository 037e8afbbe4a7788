//! The app's side of the mask views ([`super::mask_view`]): the Picture /
//! Instances / Depth choice under the preview, the requests to the mask thread
//! (started the first time a mask view is chosen), and the mask picture painted
//! in the pane instead of the rendered one.

use std::sync::Arc;

use egui::{Color32, Rect, Ui, Vec2};

use super::SwarmshotApp;
use super::mask_view::{MaskKey, MaskMaker, MaskPicture, MaskRequest, MaskResult, PaneShows};
use super::worker::LatestWorker;

/// The mask thread and what it answered.
#[derive(Default)]
pub struct MaskPane {
    worker: Option<LatestWorker<MaskRequest, MaskResult>>,
    sent: Option<MaskKey>,
    pub(super) picture: Option<MaskPicture>,
    pub(super) error: Option<(MaskKey, String)>,
    /// The texture on screen: which view of which frame it shows.
    texture: Option<(PaneShows, MaskKey, egui::TextureHandle)>,
}

impl SwarmshotApp {
    /// What the pane shows now: a mask view only when the preset asks for
    /// masks (depth only with depth maps), outside Inspect, with no problems.
    pub fn pane_shows(&self) -> PaneShows {
        let masks = &self.resolved.output.masks;
        match self.session.pane_shows {
            _ if !self.errors.is_empty() || self.session.inspect || !masks.any() => {
                PaneShows::Picture
            }
            PaneShows::Depth if !masks.depth => PaneShows::Instances,
            shows => shows,
        }
    }

    fn mask_key(&self) -> MaskKey {
        MaskKey {
            generation: self.generation,
            frame: self.session.frame,
        }
    }

    /// Ask the mask thread for this frame's masks while a mask view is on.
    pub(super) fn request_masks(&mut self, ctx: &egui::Context) {
        if self.pane_shows() == PaneShows::Picture {
            return;
        }
        let key = self.mask_key();
        if self.mask_pane.sent == Some(key) {
            return;
        }
        if self.mask_pane.worker.is_none() {
            let Some((gpu, _)) = &self.gpu else {
                return;
            };
            let mut maker = MaskMaker::new(gpu.clone());
            let wake = ctx.clone();
            match LatestWorker::spawn(
                "swarmshot masks",
                move || wake.request_repaint(),
                move |request: MaskRequest| maker.make(&request),
            ) {
                Ok(worker) => self.mask_pane.worker = Some(worker),
                Err(e) => {
                    self.notices
                        .push(format!("cannot start the mask thread: {e}"));
                    self.session.pane_shows = PaneShows::Picture;
                    return;
                }
            }
        }
        if let Some(worker) = &self.mask_pane.worker {
            worker.submit(MaskRequest {
                key,
                preset: Arc::clone(&self.resolved),
            });
            self.mask_pane.sent = Some(key);
        }
    }

    /// Take what the mask thread finished.
    pub(super) fn poll_masks(&mut self) {
        let pane = &mut self.mask_pane;
        match pane.worker.as_ref().and_then(LatestWorker::latest) {
            Some(Ok(picture)) => {
                pane.picture = Some(picture);
                pane.error = None;
            }
            Some(Err(error)) => pane.error = Some(error),
            None => {}
        }
    }

    /// Picture / Instances / Depth on a row of their own, when the preset asks for masks.
    pub(super) fn masks_toggle_ui(&mut self, ui: &mut Ui) {
        let masks = self.resolved.output.masks;
        if !masks.any() || self.session.inspect {
            return;
        }
        ui.horizontal_wrapped(|ui| self.mask_choice_ui(ui, masks));
    }

    fn mask_choice_ui(&mut self, ui: &mut Ui, masks: crate::preset::masks::MaskOutputs) {
        ui.label("Show")
            .on_hover_text("The picture, or this frame's masks as the batch writes them");
        let shows = &mut self.session.pane_shows;
        ui.radio_value(shows, PaneShows::Picture, "Picture")
            .on_hover_text("The rendered frame");
        ui.radio_value(shows, PaneShows::Instances, "Instances")
            .on_hover_text(
                "The frame's instance image as the batch writes it (output.masks): each drone's visible pixels in its own colour",
            );
        ui.add_enabled_ui(masks.depth, |ui| {
            ui.radio_value(shows, PaneShows::Depth, "Depth")
                .on_hover_text("The frame's depth map (output.masks.depth): nearer drones brighter")
                .on_disabled_hover_text("The preset asks for no depth maps (output.masks.depth)");
        });
    }

    /// Paint the mask view of the current frame into `rect`; false when the
    /// pane shows the picture (or the masks are not there yet).
    pub(super) fn paint_masks(
        &mut self,
        ctx: &egui::Context,
        painter: &egui::Painter,
        rect: Rect,
        part: Rect,
    ) -> bool {
        let shows = self.pane_shows();
        if shows == PaneShows::Picture {
            return false;
        }
        let key = self.mask_key();
        let pane = &mut self.mask_pane;
        if let Some((error_key, message)) = &pane.error
            && *error_key == key
        {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                format!("Masks failed: {message}"),
                egui::FontId::proportional(14.0),
                Color32::from_rgb(255, 120, 120),
            );
            return true;
        }
        let Some(picture) = pane.picture.as_ref().filter(|p| p.key == key) else {
            return false;
        };
        let image = match (shows, &picture.depth) {
            (PaneShows::Depth, Some(depth)) => depth,
            _ => &picture.instances,
        };
        let stale = pane
            .texture
            .as_ref()
            .is_none_or(|(s, k, _)| *s != shows || *k != key);
        if stale {
            let texture = ctx.load_texture(
                "swarmshot masks",
                image.clone(),
                egui::TextureOptions::NEAREST,
            );
            pane.texture = Some((shows, key, texture));
        }
        if let Some((_, _, texture)) = &pane.texture {
            painter.image(texture.id(), rect, part, Color32::WHITE);
        }
        let legend = match (shows, picture.depth_range_m) {
            (PaneShows::Depth, Some((near, far))) => format!(
                "depth map: white {near:.1} m (nearest) … grey {far:.1} m (farthest); black: no drone"
            ),
            _ => format!(
                "instance image: {} drones in {} pixels; black: no drone",
                picture.drones_shown, picture.pixels_shown
            ),
        };
        painter.text(
            rect.left_bottom() + Vec2::new(6.0, -6.0),
            egui::Align2::LEFT_BOTTOM,
            legend,
            egui::FontId::proportional(12.0),
            Color32::WHITE,
        );
        true
    }
}
