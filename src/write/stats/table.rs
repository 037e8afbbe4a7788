//! The report `swarmshot stats` prints: the paper's Table 2, then one table
//! per breakdown (split, model, environment, distance, class, hard negative).

use std::collections::BTreeMap;

use super::{Breakdown, DatasetStats};

impl DatasetStats {
    /// The report `swarmshot stats` prints: Table 2, then the breakdowns.
    pub fn table(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::new();
        let (min, mean, max) = self.boxes_per_frame_range();
        let [small, medium, large] = self.shares_percent();
        let resolutions: Vec<String> = self
            .resolutions
            .iter()
            .map(|(r, n)| {
                if self.resolutions.len() == 1 {
                    cell(r)
                } else {
                    format!("{} ({n})", cell(r))
                }
            })
            .collect();
        let _ = writeln!(s, "| quantity | value |\n|---|---|");
        let _ = writeln!(s, "| images | {} |", self.frames);
        let _ = writeln!(s, "| resolution | {} |", resolutions.join(", "));
        let _ = writeln!(s, "| instances (training boxes) | {} |", self.boxes);
        let _ = writeln!(
            s,
            "| UAVs per image (min / mean / max) | {min} / {mean:.2} / {max} |"
        );
        let _ = writeln!(
            s,
            "| small (√(w·h) < 32 px) | {small:.1} % ({}) |",
            self.small
        );
        let _ = writeln!(s, "| medium (32–96 px) | {medium:.1} % ({}) |", self.medium);
        let _ = writeln!(s, "| large (> 96 px) | {large:.1} % ({}) |", self.large);
        let _ = writeln!(
            s,
            "| drones placed / truncated / crowd / filtered | {} / {} / {} / {} |",
            self.drones_placed, self.truncated, self.crowd, self.filtered
        );
        let mut section = |title: &str, map: &BTreeMap<String, Breakdown>, frames: bool| {
            let _ = writeln!(
                s,
                "\n| {title} | {}boxes | small | medium | large |\n|---|{}---|---|---|---|",
                if frames { "images | " } else { "" },
                if frames { "---|" } else { "" }
            );
            for (name, b) in map {
                let name = cell(name);
                let [sm, me, la] = b.shares_percent();
                let images = if frames {
                    format!("{} | ", b.frames)
                } else {
                    String::new()
                };
                let _ = writeln!(
                    s,
                    "| {name} | {images}{} | {sm:.1} % | {me:.1} % | {la:.1} % |",
                    b.boxes
                );
            }
        };
        section("split", &self.per_split, true);
        section("model", &self.per_model, false);
        section("environment", &self.per_environment, true);
        section("distance from camera", &self.per_distance, false);
        if !self.per_class.is_empty() {
            section("class", &self.per_class, false);
        }
        if self.negatives > 0 {
            section("hard negative (manifest only)", &self.per_negative, false);
        }
        s
    }
}

/// A name read from the dataset as a table cell: no escape byte reaches the
/// terminal, and no line end or `|` breaks the table.
fn cell(text: &str) -> String {
    crate::text::printable(text).replace('|', "\\|")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_from_the_manifest_cannot_break_the_table_or_reach_the_terminal() {
        let mut stats = DatasetStats::default();
        let name = "a\nb|c\u{1b}[31m";
        stats.per_model.insert(name.into(), Breakdown::default());
        let table = stats.table();
        assert!(!table.contains('\u{1b}'), "{table}");
        let row = table
            .lines()
            .find(|l| l.starts_with("| a"))
            .expect("the model's row");
        assert!(row.starts_with("| a\\u{a}b\\|c\\u{1b}[31m | "), "{row}");
    }
}
