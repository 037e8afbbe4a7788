//! The manifest's drone records: each drone's class, attitude, label (its
//! boxes, visibility and status), drawn look, model and pose, keys in byte
//! order; the label and pose keys are shared with the confusers' records.

use crate::annotate::DroneLabel;
use crate::scene::{DronePose, FrameScene};
use crate::write::formats::json::{Decimals, Json};

/// The drones' records: each drone's label is the first label naming it.
pub(super) fn write_drones(
    j: &mut Json<'_>,
    scene: &FrameScene,
    labels: &[DroneLabel],
    model_names: &[String],
    classes: &[String],
) {
    // Labels come in drone order, so a cursor finds each drone's label
    // without a table; labels in any other order take the table.
    let ordered = labels.windows(2).all(|w| w[0].drone < w[1].drone);
    let table: Vec<Option<&DroneLabel>> = if ordered {
        Vec::new()
    } else {
        let mut label_of = vec![None; scene.drones.len()];
        for l in labels {
            if let Some(slot) = label_of.get_mut(l.drone)
                && slot.is_none()
            {
                *slot = Some(l);
            }
        }
        label_of
    };
    let mut cursor = 0;
    let with_tracks = scene.sequence.is_some();
    for (i, d) in scene.real_drones().iter().enumerate() {
        let label = if ordered {
            while cursor < labels.len() && labels[cursor].drone < i {
                cursor += 1;
            }
            labels.get(cursor).filter(|l| l.drone == i)
        } else {
            table.get(i).copied().flatten()
        };
        if i > 0 {
            j.raw(b",");
        }
        j.raw(b"{\"class\":");
        match label.and_then(|l| classes.get(l.class_id)) {
            Some(class) => j.str(class),
            None => j.raw(b"null"),
        }
        j.raw(b",\"euler_deg\":{\"pitch\":");
        j.rounded(d.euler_deg.pitch, Decimals::Six);
        j.raw(b",\"roll\":");
        j.rounded(d.euler_deg.roll, Decimals::Six);
        j.raw(b",\"yaw\":");
        j.rounded(d.euler_deg.yaw, Decimals::Six);
        j.raw(b"}");
        write_label_and_pose(j, label, scene.looks.get(i), model_names, d);
        if with_tracks {
            j.raw(b",\"track_id\":");
            j.u64(i as u64 + 1);
        }
        j.raw(b"}");
    }
}

/// The keys a drone's and a confuser's records share, in byte order:
/// `,"label":…,"model":…,"position_m":…,"quaternion_xyzw":…,"size_m":…`,
/// with `,"look":…` after the label for a drone with a drawn look.
pub(super) fn write_label_and_pose(
    j: &mut Json<'_>,
    label: Option<&DroneLabel>,
    look: Option<&crate::scene::realism::DroneLook>,
    model_names: &[String],
    d: &DronePose,
) {
    j.raw(b",\"label\":");
    match label {
        Some(l) => write_label(j, l),
        None => j.raw(b"null"),
    }
    if let Some(look) = look {
        write_look(j, look);
    }
    j.raw(b",\"model\":");
    match model_names.get(d.model) {
        Some(name) => j.str(name),
        None => j.raw(b"null"),
    }
    j.raw(b",\"position_m\":");
    j.rounded_all(&d.position.to_array(), Decimals::Nine);
    j.raw(b",\"quaternion_xyzw\":");
    j.rounded_all(&d.rotation.to_array(), Decimals::Twelve);
    j.raw(b",\"size_m\":");
    j.f64(d.size_m);
}

/// `,"look":{…}`: the drone's drawn material (`appearance` in the preset).
fn write_look(j: &mut Json<'_>, look: &crate::scene::realism::DroneLook) {
    j.raw(b",\"look\":{\"albedo\":");
    j.rounded_all(&look.albedo.map(f64::from), Decimals::Six);
    j.raw(b",\"color\":");
    j.str(look.color.name());
    j.raw(b",\"emissive\":");
    j.rounded(f64::from(look.emissive), Decimals::Six);
    j.raw(b",\"metalness\":");
    j.rounded(f64::from(look.metalness), Decimals::Six);
    j.raw(b",\"rotor_opacity\":");
    j.rounded(f64::from(look.rotor_opacity), Decimals::Six);
    j.raw(b",\"roughness\":");
    j.rounded(f64::from(look.roughness), Decimals::Six);
    j.raw(b"}");
}

pub(crate) fn write_label(j: &mut Json<'_>, l: &DroneLabel) {
    j.raw(b"{\"amodal_xyxy\":");
    let amodal = j.out.len();
    write_xyxy(j, &l.amodal);
    let amodal = amodal..j.out.len();
    j.raw(b",\"bbox_xyxy\":");
    if bits(&l.bbox) == bits(&l.amodal) {
        // The training box is the amodal one (Amodal boxes, whole in the
        // image): the same numbers, so the same bytes.
        j.out.extend_from_within(amodal);
    } else {
        write_xyxy(j, &l.bbox);
    }
    j.raw(b",\"distance_m\":");
    j.rounded(l.distance_m, Decimals::Six);
    j.raw(b",\"paper_aabb_xyxy\":");
    write_xyxy(j, &l.paper_aabb);
    j.raw(b",\"status\":");
    j.raw(status_json(l.status));
    j.raw(b",\"truncated\":");
    j.bool(l.truncated);
    let v = l.visibility;
    j.raw(b",\"unoccluded_pixels\":");
    match v {
        Some(v) => j.u64(v.unoccluded_pixels),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_fraction\":");
    match v {
        Some(v) => j.rounded(v.fraction(), Decimals::Six),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_pixels\":");
    match v {
        Some(v) => j.u64(v.visible_pixels),
        None => j.raw(b"null"),
    }
    j.raw(b",\"visible_xyxy\":");
    match v.and_then(|v| v.visible_box) {
        Some(b) => write_xyxy(j, &b),
        None => j.raw(b"null"),
    }
    j.raw(b"}");
}

/// A box's corners `[x0,y0,x1,y1]`, each rounded to 1e-6 px (`box_xyxy`).
fn write_xyxy(j: &mut Json<'_>, b: &crate::annotate::PixelBox) {
    j.rounded_all(&[b.x0, b.y0, b.x1, b.y1], Decimals::Six);
}

/// A box's corners' bit patterns (equal patterns write equal bytes).
fn bits(b: &crate::annotate::PixelBox) -> [u64; 4] {
    [b.x0, b.y0, b.x1, b.y1].map(f64::to_bits)
}

/// A label status as serde writes it (`rename_all = "lowercase"`).
pub(crate) fn status_json(status: crate::annotate::LabelStatus) -> &'static [u8] {
    use crate::annotate::LabelStatus;
    match status {
        LabelStatus::Kept => b"\"kept\"",
        LabelStatus::Crowd => b"\"crowd\"",
        LabelStatus::Filtered => b"\"filtered\"",
        LabelStatus::Negative => b"\"negative\"",
    }
}
