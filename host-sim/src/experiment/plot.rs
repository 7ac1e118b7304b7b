//! Learning-curve plots like Figs. 8.4-8.6 (plotters; PNG or SVG by file extension).

use super::report::{smooth, Report};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

use crate::error::{Error, Result};

/// Writes the three learning curves (stage 1, stage 2, combined) of `report` to `path`.
pub fn learning_curves(report: &Report, path: &Path) -> Result<()> {
    let err =
        |e: &dyn std::fmt::Display| Error::Plot(format!("cannot draw {}: {e}", path.display()));
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "svg" => {
            let root = SVGBackend::new(path, (1200, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))
        }
        "png" => {
            let root = BitMapBackend::new(path, (1200, 1000)).into_drawing_area();
            draw(report, &root).map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))
        }
        _ => Err(err(&"the plot file must end in .png or .svg")),
    }
}

type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn draw<DB: DrawingBackend>(report: &Report, root: &DrawingArea<DB, Shift>) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 3);
    let (middle, bottom) = bottom.split_vertically(bottom.dim_in_pixel().1 / 2);
    let title = format!(
        "preset {} seed {} ({} bus)",
        report.preset, report.seed, report.bus
    );
    panel(
        &top,
        &format!("Stage 1: positioning and orientation error (Fig. 8.4) - {title}"),
        &report.stage1_error_px,
    )?;
    panel(
        &middle,
        "Stage 2: positioning error (Fig. 8.5)",
        &report.stage2_error_px,
    )?;
    panel(
        &bottom,
        "Combined grasping error sqrt(e1^2 + e2^2) (Fig. 8.6)",
        &report.combined_error_px,
    )?;
    Ok(())
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
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()?;
    Ok(())
}
