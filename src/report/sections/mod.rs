//! The report's sections, in the order the README shows them, and the driver that renders them.
//!
//! Each module is one [`Section`]: it writes its Markdown, its tables (`tables/*.csv`) and
//! figures (`plots/*.svg` with their points in `plots/*.csv`). A new table is a new module and
//! one line in [`SECTIONS`]. After the sections comes the gallery of every figure they
//! returned, in their order.

mod budgets;
mod cone_profiles;
mod convergence;
mod fastest;
mod friction;
mod overview;
mod profiles;
mod robustness;
mod scaling;
mod scenes;
mod sor_omega;
mod time_to_accuracy;
mod towers;
mod warm_start;

use super::context::{Figure, ReportContext, Section};
use super::machine::Header;
use super::rel;
use super::suite::Suite;
use crate::harness::sweep::{read_histories, read_results};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The sections of the README, in order.
const SECTIONS: &[&dyn Section] = &[
    &overview::Overview,
    &budgets::Budgets,
    &scenes::Scenes,
    &towers::Towers,
    &friction::FrictionModels,
    &robustness::Robustness,
    &fastest::Fastest,
    &time_to_accuracy::TimeToAccuracy,
    &profiles::Profiles,
    &cone_profiles::ConeProfiles,
    &convergence::Convergence,
    &warm_start::WarmStart,
    &sor_omega::SorOmega,
    &scaling::Scaling,
];

/// Write README.md, tables/ and plots/ from `out_dir/data`. Returns the README path.
pub fn write_report(
    out_dir: &Path,
    suite: &Suite,
    header: &Header,
    sweep_seconds: f64,
) -> Result<PathBuf> {
    let data_dir = out_dir.join("data");
    let rows = read_results(&data_dir.join("results.csv"))?;
    let hist_path = data_dir.join("histories.csv");
    let histories = if hist_path.exists() {
        read_histories(&hist_path)?
    } else {
        Vec::new()
    };
    let ctx = ReportContext::new(suite, header, sweep_seconds, &rows, &histories, out_dir);
    std::fs::create_dir_all(&ctx.tables_dir)?;
    std::fs::create_dir_all(&ctx.plots_dir)?;
    let mut md = String::new();
    let mut figures = Vec::new();
    for section in SECTIONS {
        let shown = section
            .render(&ctx, &mut md)
            .with_context(|| format!("report section `{}`", section.title()))?;
        figures.extend(shown);
    }
    gallery(&mut md, &figures, out_dir);
    let readme = out_dir.join("README.md");
    std::fs::write(&readme, md)?;
    Ok(readme)
}

/// The closing section: every figure with its caption and a link to its data.
fn gallery(md: &mut String, figures: &[Figure], out_dir: &Path) {
    let _ = writeln!(md, "## Figures\n");
    for Figure { caption, path } in figures {
        let r = rel(path, out_dir);
        let _ = writeln!(
            md,
            "**{caption}** ([data]({}))\n\n![{caption}]({r})\n",
            rel(&path.with_extension("csv"), out_dir)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::SECTIONS;

    #[test]
    fn section_titles_are_distinct() {
        let mut titles: Vec<&str> = SECTIONS.iter().map(|s| s.title()).collect();
        titles.sort();
        titles.dedup();
        assert_eq!(titles.len(), SECTIONS.len());
    }
}
