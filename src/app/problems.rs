//! The Problems list: every validation message named by the widget it
//! belongs to, as a link that opens that panel section and scrolls the
//! message into view (the scrolling itself is done by [`super::panels::Form`]).

use egui::{RichText, Ui};

use crate::preset::FieldError;

/// The parameter sections, as titled in the left panel.
pub const SECTIONS: [&str; 12] = [
    "Models",
    "Placement",
    "Attitude",
    "Camera",
    "Scene rotation",
    "Skybox",
    "Camera model",
    "Atmosphere",
    "Drone appearance",
    "Clutter",
    "Backplates",
    "Output",
];

/// The sections of issue 21's realism stages: they start collapsed.
pub const REALISM_SECTIONS: [&str; 5] = [
    "Camera model",
    "Atmosphere",
    "Drone appearance",
    "Clutter",
    "Backplates",
];

/// "1 problem", "3 problems".
pub fn count_problems(n: usize) -> String {
    plural(n, "problem", "problems")
}

/// `n` and the noun in its number: "1 frame", "2 frames".
pub fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The section that shows `field` (`None`: the general fields above the sections).
pub fn section_of(field: &str) -> Option<&'static str> {
    let head = field.split(['.', '[']).next().unwrap_or(field);
    Some(match head {
        "models" => "Models",
        "placement" => "Placement",
        "attitude" => "Attitude",
        "camera" => "Camera",
        "plane" => "Scene rotation",
        "sky" => "Skybox",
        "camera_model" => "Camera model",
        "atmosphere" => "Atmosphere",
        "appearance" => "Drone appearance",
        "clutter" => "Clutter",
        "backplate" => "Backplates",
        "render" | "output" | "labels" => "Output",
        _ => return None,
    })
}

/// The name a user sees next to the widget of `field` (`camera.z.step` → "CameraZ step").
pub fn field_label(field: &str) -> String {
    let parts: Vec<&str> = field.split('.').collect();
    let sweep = |name: &str| match parts.get(2) {
        Some(part) => format!("{name} {part}"),
        None => name.to_string(),
    };
    match parts.as_slice() {
        ["camera", "x", ..] => sweep("CameraX"),
        ["camera", "y", ..] => sweep("CameraY"),
        ["camera", "z", ..] => sweep("CameraZ"),
        ["camera", "fov_y_deg"] => "Field of view".into(),
        ["camera", "observer", part] => match *part {
            "elevation_deg" => "Observer elevation".into(),
            "azimuth_deg" => "Observer azimuth".into(),
            "distance_m" => "Observer distance".into(),
            "size_px" => "Observer apparent size".into(),
            other => format!("Observer {other}"),
        },
        ["camera_model", "psf", "sigma_px"] => "Blur σ".into(),
        ["camera_model", "psf", "radius_px"] => "Disc radius".into(),
        ["camera_model", name] => match *name {
            "exposure_ev" => "Exposure".into(),
            "white_balance_red" => "White balance red".into(),
            "white_balance_blue" => "White balance blue".into(),
            "vignetting" => "Vignetting".into(),
            "ca_red_scale" => "CA red scale".into(),
            "ca_blue_scale" => "CA blue scale".into(),
            "shot_noise_gain" => "Shot noise gain".into(),
            "read_noise_levels" => "Read noise".into(),
            "sensor_scale" => "Sensor scale".into(),
            "jpeg_quality" => "Camera JPEG quality".into(),
            "recompress_quality" => "Recompress quality".into(),
            other => format!("Camera model {other}"),
        },
        ["atmosphere", "visibility_m"] => "Visibility".into(),
        ["backplate", name] => match *name {
            "folder" => "Folder".into(),
            "hfov_deg" => "Horizontal field of view".into(),
            "horizon" => "Horizon".into(),
            "elevation_deg" => "Elevation".into(),
            "sun_elevation_deg" => "Sun elevation".into(),
            "sun_azimuth_deg" => "Sun azimuth".into(),
            other => format!("Backplate {other}"),
        },
        ["appearance", name] => match *name {
            "palette" => "Palette weights".into(),
            "roughness" => "Roughness".into(),
            "metalness" => "Metalness".into(),
            "emissive_share" => "Lights share".into(),
            "emissive_strength" => "Light strength".into(),
            other => format!("Appearance {other}"),
        },
        ["plane", "rx", ..] => sweep("PlaneRX"),
        ["plane", "ry", ..] => sweep("PlaneRY"),
        ["plane", "rz", ..] => sweep("PlaneRZ"),
        ["placement", "x_count"] => "XCount".into(),
        ["placement", "y_count"] => "YCount".into(),
        ["placement", "z_count"] => "ZCount".into(),
        ["placement", "load_factor"] => "LoadFactor".into(),
        ["placement", "count"] => "Count".into(),
        ["placement", "volume", "size_m", axis] => format!("Volume size {axis}"),
        ["placement", "volume", "per_m3"] => "Density".into(),
        ["placement", "min_separation_m"] => "Min separation".into(),
        ["placement"] => "Placement".into(),
        ["attitude", name] => match *name {
            "roll_deg" => "Roll".into(),
            "pitch_deg" => "Pitch".into(),
            "yaw_deg" => "Yaw".into(),
            other => other.to_string(),
        },
        ["output", "split"] => "Split".into(),
        ["output", "split", part] => format!("Split {part}"),
        ["output", "image_format", "quality"] => "JPEG quality".into(),
        ["render", "resolution", "width"] => "Width".into(),
        ["render", "resolution", "height"] => "Height".into(),
        ["render", "msaa"] => "MSAA".into(),
        ["labels", "min_box_px"] => "Min box".into(),
        ["labels", "min_visible_fraction"] => "Min visible fraction".into(),
        ["labels", "id_scale"] => "Id pass scale".into(),
        ["sky", "sun_elevation_deg"] => "Sun elevation".into(),
        ["sky", "sun_azimuth_deg"] => "Sun azimuth".into(),
        ["sky", "cloud_cover"] => "Cloud cover".into(),
        ["sky", "zenith"] => "Zenith colour".into(),
        ["sky", "horizon"] => "Horizon colour".into(),
        [model, part] if model.starts_with("models[") => {
            let number = model
                .trim_start_matches("models[")
                .trim_end_matches(']')
                .parse::<usize>()
                .map_or_else(|_| "?".to_string(), |i| (i + 1).to_string());
            match *part {
                "size_m" => format!("Model {number} size"),
                "class" => format!("Model {number} class"),
                _ => format!("Model {number}"),
            }
        }
        ["models"] => "Models".into(),
        ["name"] => "Name".into(),
        ["seed"] => "Seed".into(),
        ["repeats"] => "Repeats".into(),
        _ => field.to_string(),
    }
}

/// The list; returns the field whose link was clicked.
pub fn problems_ui(ui: &mut Ui, errors: &[FieldError]) -> Option<String> {
    if errors.is_empty() {
        return None;
    }
    let mut clicked = None;
    ui.label(
        RichText::new(format!("Problems ({})", errors.len()))
            .strong()
            .color(ui.visuals().error_fg_color),
    );
    for error in errors {
        let text = format!("{}: {}", field_label(&error.field), error.message);
        let where_ = section_of(&error.field).unwrap_or("the top of the parameters");
        if ui
            .link(text)
            .on_hover_text(format!("Show it in {where_} ({})", error.field))
            .clicked()
        {
            clicked = Some(error.field.clone());
        }
    }
    clicked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_named_as_their_widgets() {
        assert_eq!(field_label("camera.z.step"), "CameraZ step");
        assert_eq!(field_label("camera.z"), "CameraZ");
        assert_eq!(field_label("output.split.train"), "Split train");
        assert_eq!(field_label("models[1].size_m"), "Model 2 size");
        assert_eq!(field_label("placement.volume.size_m.y"), "Volume size y");
        assert_eq!(field_label("something.new"), "something.new");
        assert_eq!(section_of("plane.ry.step"), Some("Scene rotation"));
        assert_eq!(section_of("models[0].class"), Some("Models"));
        assert_eq!(section_of("labels.id_scale"), Some("Output"));
        assert_eq!(section_of("seed"), None);
        assert_eq!(field_label("atmosphere.visibility_m"), "Visibility");
        assert_eq!(field_label("camera_model.psf.sigma_px"), "Blur σ");
        assert_eq!(
            field_label("camera.observer.distance_m"),
            "Observer distance"
        );
        assert_eq!(section_of("camera_model.exposure_ev"), Some("Camera model"));
        assert_eq!(section_of("appearance.palette"), Some("Drone appearance"));
        assert_eq!(section_of("backplate.hfov_deg"), Some("Backplates"));
        assert_eq!(
            field_label("backplate.hfov_deg"),
            "Horizontal field of view"
        );
        assert_eq!(section_of("camera.observer.size_px"), Some("Camera"));
        for field in [
            "camera.x",
            "sky.zenith",
            "placement.count",
            "attitude.yaw_deg",
            "atmosphere.visibility_m",
        ] {
            assert!(SECTIONS.contains(&section_of(field).unwrap_or("none")));
        }
    }
}
