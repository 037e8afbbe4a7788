//! The Problems list: every validation message named by the widget it
//! belongs to, as a link that opens that panel section and scrolls the
//! message into view (the scrolling itself is done by [`super::panels::Form`]).
//! Labels and sections come from the table of fields ([`crate::preset::fields`]).

use egui::{RichText, Ui};

use crate::preset::FieldError;
use crate::preset::fields::{label_of, section_of};

/// The sections of issue 21's realism stages: they start collapsed (most
/// presets leave them off).
pub const COLLAPSED_SECTIONS: [&str; 7] = [
    "Camera model",
    "Thermal camera",
    "Atmosphere",
    "Drone appearance",
    "Clutter",
    "Weather",
    "Backplates",
];

/// "1 problem", "3 problems".
pub fn count_problems(n: usize) -> String {
    crate::text::plural(n as u64, "problem", "problems")
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
        let text = format!("{}: {}", label_of(&error.field), error.message);
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
    fn the_collapsed_sections_are_sections() {
        for title in COLLAPSED_SECTIONS {
            assert!(crate::preset::fields::SECTIONS.contains(&title), "{title}");
        }
    }

    #[test]
    fn counts_read_in_their_number() {
        assert_eq!(count_problems(1), "1 problem");
        assert_eq!(count_problems(3), "3 problems");
    }
}
