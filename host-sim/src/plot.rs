//! Learning-curve plots (plotters; PNG or SVG by file extension): frozen snapshots on the
//! held-out targets with the fixed move budget (what measures learning), and the paper-style
//! end-of-trial curves of Figs. 8.4-8.5 (which follow the tolerance schedule tol(t)).

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use trn_lab::report::{smooth, Report};

/// A plot's result: what went wrong, for the caller to name the file.
pub type Result<T> = std::result::Result<T, String>;

/// Writes the three learning curves (stage 1, stage 2, combined) of `report` to `path`.
pub fn learning_curves(report: &Report, path: &Path) -> Result<()> {
    let err = |e: &dyn std::error::Error| format!("cannot draw: {}", plain(e));
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "svg" => {
            let root = SVGBackend::new(path, (1200, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&*e))?;
            root.present().map_err(|e| err(&e))
        }
        "png" => {
            let root = BitMapBackend::new(path, (1200, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&*e))?;
            root.present().map_err(|e| err(&e))
        }
        _ => Err("the plot file must end in .png or .svg".into()),
    }
}

type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// A drawing error as a user reads it: the innermost cause (plotters' errors print their
/// inner errors as debug dumps), an operating-system error by its own words.
fn plain(e: &dyn std::error::Error) -> String {
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

/// Draws the series labels of `chart` in a framed box.
fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<
        'a,
        DB,
        Cartesian2d<plotters::coord::types::RangedCoordf32, LogCoord<f32>>,
    >,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    Ok(())
}

fn draw<DB: DrawingBackend>(report: &Report, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let (tl, tr) = top.split_horizontally(top.dim_in_pixel().0 / 2);
    let (bl, br) = bottom.split_horizontally(bottom.dim_in_pixel().0 / 2);
    let title = format!("{} seed {}", report.preset, report.seed);
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
        "Stage 1 end-of-trial error in training (Fig. 8.4; follows tol(t))",
        &report.stage1_error_px,
    )?;
    panel(
        &br,
        "Stage 2 end-of-trial error in training (Fig. 8.5; follows tol(t))",
        &report.stage2_error_px,
    )?;
    Ok(())
}

/// The learning curve that measures the networks: frozen snapshots on the held-out
/// deployment-style targets, noise-free error after the coarse move and fine moves 1-3.
fn snapshots<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    report: &Report,
    pick: impl Fn(&trn_lab::report::SnapshotPoint) -> &Vec<f32>,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let curve = &report.learning_curve;
    let xmax = curve.last().map(|p| p.trial).unwrap_or(1).max(1) as f32;
    let ymax = curve
        .iter()
        .filter_map(|p| pick(p).first().copied())
        .filter(|x| x.is_finite())
        .fold(10.0f32, f32::max)
        .min(500.0);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(0f32..xmax * 1.02, (0.3f32..ymax * 1.5).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("training trials")
        .y_desc("noise-free error (pixels)")
        .draw()?;
    let colours = [RED, BLUE, GREEN, MAGENTA];
    for (m, name) in [
        "coarse move",
        "after 1 fine move",
        "after 2 fine moves",
        "after 3 fine moves",
    ]
    .iter()
    .enumerate()
    {
        let c = colours[m];
        let pts: Vec<(f32, f32)> = curve
            .iter()
            .filter_map(|p| pick(p).get(m).map(|&e| (p.trial as f32, e.max(0.3))))
            .filter(|(_, e)| e.is_finite())
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(pts.into_iter().map(move |p| Circle::new(p, 3, c.filled())))?;
    }
    legend(&mut chart)
}

fn panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, caption: &str, y: &[f32]) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let n = y.len().max(2);
    let ymax = y.iter().cloned().fold(1.0f32, f32::max).min(200.0);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(0f32..n as f32, (0.1f32..ymax * 1.2).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("trial")
        .y_desc("error (pixels)")
        .draw()?;
    chart
        .draw_series(
            y.iter()
                .enumerate()
                .map(|(i, &e)| Circle::new((i as f32, e.max(0.1)), 2, BLUE.mix(0.35).filled())),
        )?
        .label("per trial")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    let s = smooth(y, 21);
    chart
        .draw_series(LineSeries::new(
            s.iter().enumerate().map(|(i, &e)| (i as f32, e.max(0.1))),
            RED.stroke_width(2),
        ))?
        .label("mean over 21 trials")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    chart
        .draw_series(LineSeries::new(
            [(0.0, 3.0), (n as f32, 3.0)],
            BLACK.mix(0.5),
        ))?
        .label("3 px")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.5)));
    legend(&mut chart)
}

/// Error over the floor and grasp success against trials, one line per controller.
pub fn lifelong(curves: &[trn_lab::lifelong::Curve], path: &std::path::Path) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| format!("cannot draw: {e}");
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (1200, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(600);
        let xmax = curves
            .iter()
            .flat_map(|c| c.snapshots.last().map(|p| p.trial))
            .max()
            .unwrap_or(1) as f32;
        let colours = [RED, BLUE, GREEN, MAGENTA];
        let ymax = curves
            .iter()
            .flat_map(|c| c.ratios())
            .map(|(_, r)| r)
            .filter(|r| r.is_finite())
            .fold(2.0f32, f32::max)
            .min(20.0);
        let mut chart = ChartBuilder::on(&left)
            .caption("error after the budget / noise floor", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0f32..xmax * 1.02, 0.8f32..ymax * 1.1)?;
        chart.configure_mesh().x_desc("trials per network").draw()?;
        for (c, colour) in curves.iter().zip(colours) {
            let pts: Vec<(f32, f32)> = c
                .ratios()
                .into_iter()
                .filter(|(_, r)| r.is_finite())
                .map(|(t, r)| (t as f32, r))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
                .label(c.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        let mut chart = ChartBuilder::on(&right)
            .caption("grasp success (%)", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0f32..xmax * 1.02, 0f32..102f32)?;
        chart.configure_mesh().x_desc("trials per network").draw()?;
        for (c, colour) in curves.iter().zip(colours) {
            let pts: Vec<(f32, f32)> = c
                .snapshots
                .iter()
                .filter(|p| p.grasp_success.is_finite())
                .map(|p| (p.trial as f32, 100.0 * p.grasp_success))
                .collect();
            chart.draw_series(LineSeries::new(pts, colour.stroke_width(2)))?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| err(&*e))
}
