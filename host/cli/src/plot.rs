//! Learning-curve plots (plotters; PNG or SVG by file extension): frozen snapshots on the
//! held-out targets with the fixed move budget (what measures learning), and the paper-style
//! end-of-trial curves of Figs. 8.4-8.5 (which follow the tolerance schedule tol(t)).
//!
//! Every picture draws its text with the bundled DejaVu Sans ([`fonts`]: the same glyphs on
//! every machine, whatever fonts it has), its legends beside the data (never on it), and
//! counts (trials) as integers.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use trn_bench::report::{smooth, Report};

/// A plot's result: what went wrong, for the caller to name the file.
pub type Result<T> = std::result::Result<T, String>;

/// The bundled font (DejaVu Sans; its licence is `assets/DejaVuSans.LICENSE`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the bundled font as plotters' `sans-serif` (once; every picture calls it).
pub fn fonts() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        for style in [
            FontStyle::Normal,
            FontStyle::Bold,
            FontStyle::Italic,
            FontStyle::Oblique,
        ] {
            // the bytes are the font's own: a failure here is a corrupt checkout
            plotters::style::register_font("sans-serif", style, FONT)
                .unwrap_or_else(|_| panic!("assets/DejaVuSans.ttf is not a font"));
        }
    });
}

/// Colours of a series by index (distinguishable in print and for most colour vision).
pub const PALETTE: [RGBColor; 8] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// A line.
    Line,
    /// A dot.
    Dot,
    /// A line with a marker of shape `n` (0 circle, 1 triangle, 2 square, 3 cross).
    Marked(usize),
}

/// Width of the legend strip beside a chart (pixels).
pub const LEGEND_W: u32 = 200;

/// Draws marker `shape` (0 circle, 1 triangle, 2 square, 3 cross) at `p` on any area.
fn marker<DB: DrawingBackend, C: plotters::coord::CoordTranslate>(
    area: &DrawingArea<DB, C>,
    p: C::From,
    shape: usize,
    colour: RGBColor,
) -> DrawResult
where
    DB::ErrorType: 'static,
    C::From: Clone,
{
    match shape % 4 {
        0 => area.draw(&Circle::new(p, 4, colour.filled()))?,
        1 => area.draw(&TriangleMarker::new(p, 6, colour.filled()))?,
        2 => {
            area.draw(&(EmptyElement::at(p) + Rectangle::new([(-4, -4), (4, 4)], colour.filled())))?
        }
        _ => area.draw(&Cross::new(p, 5, colour.stroke_width(2)))?,
    }
    Ok(())
}

/// A legend in its own strip beside a chart: one entry a mark and a name, a long name
/// wrapped onto a second line (at the strip's width).
pub fn side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, RGBColor, Mark)],
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let font = ("sans-serif", 15).into_font();
    // about 8 pixels a character at this size, after the mark
    let chars = (area.dim_in_pixel().0.saturating_sub(40) / 8).max(8) as usize;
    let mut y = 48;
    for (name, c, mark) in entries {
        match mark {
            Mark::Line => area.draw(&PathElement::new(vec![(6, y), (30, y)], c.stroke_width(2)))?,
            Mark::Dot => area.draw(&Circle::new((18, y), 4, c.filled()))?,
            Mark::Marked(s) => {
                area.draw(&PathElement::new(vec![(6, y), (30, y)], c.stroke_width(2)))?;
                marker(area, (18, y), *s, *c)?;
            }
        }
        for line in wrap(name, chars) {
            area.draw(&Text::new(line, (36, y - 8), font.clone()))?;
            y += 18;
        }
        y += 8;
    }
    Ok(())
}

/// `s` in lines of at most `width` characters, broken at spaces (a longer word alone).
fn wrap(s: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in s.split(' ') {
        match lines.last_mut() {
            Some(l) if l.len() + 1 + word.len() <= width => {
                l.push(' ');
                l.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// The chart's area and its legend strip.
pub fn with_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    let w = area.dim_in_pixel().0;
    area.split_horizontally(w.saturating_sub(LEGEND_W))
}

/// An integer tick label (counts: trials, moves).
pub fn integer(x: &f32) -> String {
    format!("{:.0}", x)
}

/// A tick label without trailing zeros (`100`, `0.5`).
pub fn plain(x: &f32) -> String {
    format!("{x}")
}

/// Writes the learning curves (stage 1, stage 2 snapshots; both training curves) of
/// `report` to `path`.
pub fn learning_curves(report: &Report, path: &Path) -> Result<()> {
    fonts();
    let err = |e: &dyn std::error::Error| format!("cannot draw: {}", plain_error(e));
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "svg" => {
            let root = SVGBackend::new(path, (1500, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&*e))?;
            root.present().map_err(|e| err(&e))
        }
        "png" => {
            let root = BitMapBackend::new(path, (1500, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&*e))?;
            root.present().map_err(|e| err(&e))
        }
        _ => Err("the plot file must end in .png or .svg".into()),
    }
}

/// A drawing's result.
pub type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// A drawing error as a user reads it: the innermost cause (plotters' errors print their
/// inner errors as debug dumps), an operating-system error by its own words.
fn plain_error(e: &dyn std::error::Error) -> String {
    let mut inner = e;
    while let Some(s) = inner.source() {
        inner = s;
    }
    let text = inner.to_string();
    if let Some(code) = text
        .split("os error ")
        .nth(1)
        .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse::<i32>().ok())
    {
        return std::io::Error::from_raw_os_error(code).to_string();
    }
    text
}

fn draw<DB: DrawingBackend>(report: &Report, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let (tl, tr) = top.split_horizontally(top.dim_in_pixel().0 / 2);
    let (bl, br) = bottom.split_horizontally(bottom.dim_in_pixel().0 / 2);
    let title = format!("{} seed {}", report.label(), report.seed);
    snapshots(
        &tl,
        &format!("Stage 1, frozen snapshots, held-out ({title})"),
        report,
        |p| &p.stage1_true_px,
    )?;
    snapshots(&tr, "Stage 2, frozen snapshots, held-out", report, |p| {
        &p.stage2_true_px
    })?;
    panel(
        &bl,
        "Stage 1 end-of-trial error in training (Fig. 8.4; tol(t))",
        &report.stage1_error_px,
    )?;
    panel(
        &br,
        "Stage 2 end-of-trial error in training (Fig. 8.5; tol(t))",
        &report.stage2_error_px,
    )?;
    Ok(())
}

/// The learning curve that measures the networks: frozen snapshots on the held-out
/// deployment-style targets, noise-free error after the coarse move and after every fine
/// move of the budget.
fn snapshots<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    report: &Report,
    pick: impl Fn(&trn_bench::report::SnapshotPoint) -> &Vec<f32>,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let curve = &report.learning_curve;
    if curve.is_empty() {
        return no_snapshots(area, caption);
    }
    let (area, side) = with_legend(area);
    let xmax = curve.last().map(|p| p.trial).unwrap_or(1).max(1) as f32;
    let ymax = curve
        .iter()
        .filter_map(|p| pick(p).first().copied())
        .filter(|x| x.is_finite())
        .fold(10.0f32, f32::max)
        .min(500.0);
    let moves = curve.iter().map(|p| pick(p).len()).max().unwrap_or(0);
    let mut chart = ChartBuilder::on(&area)
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f32..xmax * 1.02, (0.3f32..ymax * 1.5).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("training trials per network")
        .y_desc("noise-free error (pixels)")
        .x_labels(count_labels(xmax))
        .x_label_formatter(&integer)
        .y_label_formatter(&plain)
        .label_style(("sans-serif", 14))
        .draw()?;
    let mut entries = Vec::new();
    for m in 0..moves {
        let c = PALETTE[m % PALETTE.len()];
        let pts: Vec<(f32, f32)> = curve
            .iter()
            .filter_map(|p| pick(p).get(m).map(|&e| (p.trial as f32, e.max(0.3))))
            .filter(|(_, e)| e.is_finite())
            .collect();
        chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?;
        for p in pts {
            marker(chart.plotting_area(), p, m, c)?;
        }
        let name = match m {
            0 => "coarse move".to_string(),
            1 => "after 1 fine move".to_string(),
            n => format!("after {n} fine moves"),
        };
        entries.push((name, c, Mark::Marked(m)));
    }
    side_legend(&side, &entries)
}

/// A panel of snapshots for a run that took none (`--snapshot-every 0`): its caption and
/// a line that says so, instead of empty axes.
fn no_snapshots<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, caption: &str) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (w, h) = area.dim_in_pixel();
    area.draw_text(caption, &("sans-serif", 18).into_text_style(area), (10, 10))?;
    area.draw_text(
        "no snapshots: the run took none (--snapshot-every 0)",
        &("sans-serif", 16)
            .into_text_style(area)
            .color(&BLACK.mix(0.6)),
        (w as i32 / 6, h as i32 / 2),
    )?;
    Ok(())
}

/// Trials a training panel's mean runs over.
const SMOOTHING: usize = 21;

/// How many tick labels an axis of counts from 0 to `max` gets: at most one per whole
/// number (so no two ticks read the same), at most 10.
fn count_labels(max: f32) -> usize {
    (max.max(1.0).floor() as usize + 1).min(10)
}

fn panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, caption: &str, y: &[f32]) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (area, side) = with_legend(area);
    let n = y.len().max(2);
    let ymax = y.iter().cloned().fold(1.0f32, f32::max).min(200.0);
    let mut chart = ChartBuilder::on(&area)
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f32..n as f32, (0.1f32..ymax * 1.2).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("training trial")
        .y_desc("error (pixels)")
        .x_labels(count_labels(n as f32))
        .x_label_formatter(&integer)
        .y_label_formatter(&plain)
        .label_style(("sans-serif", 14))
        .draw()?;
    let dots = PALETTE[1];
    chart.draw_series(
        y.iter()
            .enumerate()
            .map(|(i, &e)| Circle::new((i as f32, e.max(0.1)), 2, dots.mix(0.35).filled())),
    )?;
    let s = smooth(y, SMOOTHING);
    chart.draw_series(LineSeries::new(
        s.iter().enumerate().map(|(i, &e)| (i as f32, e.max(0.1))),
        PALETTE[0].stroke_width(2),
    ))?;
    chart.draw_series(LineSeries::new(
        [(0.0, 3.0), (n as f32, 3.0)],
        BLACK.mix(0.5),
    ))?;
    side_legend(
        &side,
        &[
            ("each trial".into(), dots, Mark::Dot),
            (
                format!("mean over {} trials", SMOOTHING.min(y.len().max(1))),
                PALETTE[0],
                Mark::Line,
            ),
            ("3 px".into(), RGBColor(128, 128, 128), Mark::Line),
        ],
    )
}

/// Error over the floor and grasp success against trials, one line per controller, each
/// with its own marker and set a little apart along the trials (lines that coincide, as the
/// grasp rates at 100 % do, stay told apart), one legend beside both panels.
pub fn lifelong(curves: &[trn_studies::lifelong::Curve], path: &std::path::Path) -> Result<()> {
    fonts();
    let err = |e: &dyn std::error::Error| format!("cannot draw: {}", plain_error(e));
    let draw = || -> DrawResult {
        let root = BitMapBackend::new(path, (1500, 520)).into_drawing_area();
        root.fill(&WHITE)?;
        let (charts, side) = root.split_horizontally(1500 - 260);
        let (left, right) = charts.split_horizontally(620);
        let xmax = curves
            .iter()
            .flat_map(|c| c.snapshots.last().map(|p| p.trial))
            .max()
            .unwrap_or(1) as f32;
        let ymax = curves
            .iter()
            .flat_map(|c| c.ratios())
            .map(|(_, r)| r)
            .filter(|r| r.is_finite())
            .fold(2.0f32, f32::max)
            .min(20.0);
        // each controller's points moved by a fraction of the axis, centred on the trial
        let n = curves.len() as f32;
        let dodge = |i: usize, t: f32| t + (i as f32 - (n - 1.0) / 2.0) * xmax * 0.025;
        let series: Vec<Vec<(f32, f32)>> = curves
            .iter()
            .enumerate()
            .map(|(i, c)| {
                c.ratios()
                    .into_iter()
                    .filter(|(_, r)| r.is_finite())
                    .map(|(t, r)| (dodge(i, t as f32), r))
                    .collect()
            })
            .collect();
        let grasps: Vec<Vec<(f32, f32)>> = curves
            .iter()
            .enumerate()
            .map(|(i, c)| {
                c.snapshots
                    .iter()
                    .filter(|p| p.grasp_success.is_finite())
                    .map(|p| (dodge(i, p.trial as f32), 100.0 * p.grasp_success))
                    .collect()
            })
            .collect();
        for (area, caption, ylo, yhi, data) in [
            (
                &left,
                "error after the budget / noise floor",
                0.8f32,
                ymax * 1.1,
                &series,
            ),
            (&right, "grasp success (%)", 0.0, 106.0, &grasps),
        ] {
            let mut chart = ChartBuilder::on(area)
                .caption(caption, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(0f32..xmax * 1.04, ylo..yhi)?;
            chart
                .configure_mesh()
                .x_desc("trials per network")
                .x_label_formatter(&integer)
                .y_label_formatter(&plain)
                .label_style(("sans-serif", 14))
                .draw()?;
            for (i, pts) in data.iter().enumerate() {
                let c = PALETTE[i % PALETTE.len()];
                chart.draw_series(LineSeries::new(pts.clone(), c.mix(0.6).stroke_width(2)))?;
                for &p in pts {
                    marker(chart.plotting_area(), p, i, c)?;
                }
            }
        }
        let entries: Vec<(String, RGBColor, Mark)> = curves
            .iter()
            .enumerate()
            .map(|(i, c)| (c.name.clone(), PALETTE[i % PALETTE.len()], Mark::Marked(i)))
            .collect();
        side_legend(&side, &entries)?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| err(&*e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_legend_names_wrap_at_spaces() {
        assert_eq!(
            wrap("project, frozen after the initial training", 20),
            vec!["project, frozen", "after the initial", "training"]
        );
        assert_eq!(wrap("short", 20), vec!["short"]);
        assert_eq!(integer(&50.0), "50");
        // 5 trials: the ticks 0 to 5, not 0 0 1 1 2 ...; many trials: 10
        assert_eq!(count_labels(5.0), 6);
        assert_eq!(count_labels(0.0), 2);
        assert_eq!(count_labels(300.0), 10);
        assert_eq!(plain(&100.0), "100");
    }
}
