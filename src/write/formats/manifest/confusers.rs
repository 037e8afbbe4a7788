//! The manifest's `confusers` records (issue 22): one per placed bird,
//! aircraft or balloon, with its kind, class (`null`: an unlabelled hard
//! negative), pose, wing-beat phase and label (boxes, visible pixels and
//! status `negative`, `kept`, `crowd` or `filtered`). Written only when the
//! frame has confusers, so other manifests keep their bytes.

use crate::annotate::DroneLabel;
use crate::scene::FrameScene;
use crate::write::formats::json::{Decimals, Json};

/// The frame's confusers as a JSON array body (without the brackets), keys in byte order.
pub(crate) fn write_confusers(
    j: &mut Json<'_>,
    scene: &FrameScene,
    labels: &[DroneLabel],
    model_names: &[String],
    classes: &[String],
) {
    let first = scene.drone_count();
    let mut label_of: Vec<Option<&DroneLabel>> = vec![None; scene.confusers.len()];
    for l in labels {
        if let Some(slot) = l.drone.checked_sub(first).and_then(|k| label_of.get_mut(k))
            && slot.is_none()
        {
            *slot = Some(l);
        }
    }
    let with_tracks = scene.sequence.is_some();
    for (k, (c, d)) in scene
        .confusers
        .iter()
        .zip(&scene.drones[first..])
        .enumerate()
    {
        if k > 0 {
            j.raw(b",");
        }
        let label = label_of[k];
        j.raw(b"{\"class\":");
        match label
            .and_then(|l| classes.get(l.class_id))
            .filter(|_| !c.is_negative())
        {
            Some(class) => j.str(class),
            None => j.raw(b"null"),
        }
        j.raw(b",\"flap_hz\":");
        match c.flap_hz {
            Some(hz) => j.rounded(hz, Decimals::Six),
            None => j.raw(b"null"),
        }
        j.raw(b",\"flap_phase\":");
        match c.flap_phase {
            Some(p) => j.rounded(p, Decimals::Six),
            None => j.raw(b"null"),
        }
        j.raw(b",\"flock\":");
        match c.flock {
            Some(f) => j.u64(f as u64),
            None => j.raw(b"null"),
        }
        j.raw(b",\"kind\":");
        j.str(c.kind.name());
        super::drones::write_label_and_pose(j, label, None, model_names, d);
        j.raw(b",\"span_m\":");
        j.rounded(c.span_m, Decimals::Six);
        j.raw(b",\"speed_m_s\":");
        j.rounded(c.speed_m_s, Decimals::Six);
        if with_tracks {
            j.raw(b",\"track_id\":");
            j.u64((first + k) as u64 + 1);
        }
        j.raw(b"}");
    }
}
