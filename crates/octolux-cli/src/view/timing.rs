//! Pass times of the last frames: a ring of per-frame timings, drawn as stacked bars (one
//! colour per pass, oldest frame on the left), and the frame-rate summary printed at exit.

use egui::{Color32, Rect, Sense, Stroke, Ui, Vec2};
use octolux::gpu::PassTiming;
use std::collections::VecDeque;

/// Frames kept for the graph.
pub const HISTORY: usize = 120;
/// Frames at the start and at the end of a run whose rates the exit summary compares.
const ENDS: usize = 100;

/// The pass times of the last [`HISTORY`] frames and wall-clock frame-time statistics of the
/// run, in constant memory however long it runs.
#[derive(Default)]
pub struct TimingHistory {
    frames: VecDeque<Vec<PassTiming>>,
    /// Pass names in first-seen order, so each keeps its colour.
    names: Vec<String>,
    /// Wall-clock seconds of the first [`ENDS`] frames.
    first: Vec<f32>,
    /// Wall-clock seconds of the last [`ENDS`] frames.
    last: VecDeque<f32>,
    count: usize,
    total: f64,
    worst: f32,
}

impl TimingHistory {
    /// Adds a frame's pass times.
    pub fn push(&mut self, timings: Vec<PassTiming>) {
        for t in &timings {
            if !self.names.contains(&t.name) {
                self.names.push(t.name.clone());
            }
        }
        if self.frames.len() == HISTORY {
            self.frames.pop_front();
        }
        self.frames.push_back(timings);
    }

    /// Forgets the pass times (the technique changed: its passes differ).
    pub fn clear_passes(&mut self) {
        self.frames.clear();
        self.names.clear();
    }

    /// Adds a frame's wall-clock time in seconds.
    pub fn push_wall(&mut self, seconds: f32) {
        if self.first.len() < ENDS {
            self.first.push(seconds);
        }
        if self.last.len() == ENDS {
            self.last.pop_front();
        }
        self.last.push_back(seconds);
        self.count += 1;
        self.total += seconds as f64;
        self.worst = self.worst.max(seconds);
    }

    /// Mean time per pass over the kept frames, in first-seen order.
    pub fn means(&self) -> Vec<PassTiming> {
        let frames: Vec<Vec<PassTiming>> = self.frames.iter().cloned().collect();
        crate::stats::average_timings(&frames)
    }

    /// The most recent frame's pass times.
    pub fn latest(&self) -> Option<&[PassTiming]> {
        self.frames.back().map(|f| f.as_slice())
    }

    /// Mean wall-clock frame time (s) over the last `n` (at most 100) frames.
    pub fn mean_wall(&self, n: usize) -> Option<f32> {
        let recent: Vec<f32> = self.last.iter().rev().take(n).copied().collect();
        (!recent.is_empty()).then(|| recent.iter().sum::<f32>() / recent.len() as f32)
    }

    /// Frame-rate summary of the whole run: frames, mean and worst frame time, and the frame
    /// rate over the first and the last k frames, k = 100 or half the run if shorter (a run
    /// that holds its rate has the two close).
    pub fn summary(&self) -> String {
        let n = self.count;
        if n == 0 {
            return "no frames rendered".into();
        }
        let k = ENDS.min(n / 2).max(1);
        let rate = |s: &mut dyn Iterator<Item = &f32>| {
            let (k, sum) = s.fold((0usize, 0f32), |(k, sum), x| (k + 1, sum + x));
            k as f32 / sum.max(1e-9)
        };
        format!(
            "{n} frames in {:.1} s: mean {:.1} ms ({:.2} fps), worst {:.1} ms; first {k} frames \
             {:.2} fps, last {k} frames {:.2} fps",
            self.total,
            self.total / n as f64 * 1e3,
            n as f64 / self.total.max(1e-9),
            self.worst * 1e3,
            rate(&mut self.first.iter().take(k)),
            rate(&mut self.last.iter().rev().take(k)),
        )
    }

    /// Colour of pass `i`: golden-angle hues, so neighbours differ.
    fn colour(i: usize) -> Color32 {
        let hue = (i as f32 * 0.618_034).fract();
        egui::ecolor::Hsva::new(hue, 0.65, 0.9, 1.0).into()
    }

    /// Draws the stacked bar graph with a legend (name, mean ms).
    pub fn graph(&self, ui: &mut Ui) {
        let height = 90.0;
        let width = ui.available_width().max(120.0);
        let (response, painter) = ui.allocate_painter(Vec2::new(width, height), Sense::hover());
        let rect = response.rect;
        painter.rect_filled(rect, 2.0, Color32::from_gray(24));
        let totals: Vec<f64> = self
            .frames
            .iter()
            .map(|f| f.iter().map(|t| t.ms).sum())
            .collect();
        let max = totals.iter().copied().fold(1e-3, f64::max);
        let bar = rect.width() / HISTORY as f32;
        let offset = HISTORY - self.frames.len();
        for (i, frame) in self.frames.iter().enumerate() {
            let x = rect.left() + (offset + i) as f32 * bar;
            let mut y = rect.bottom();
            for t in frame {
                let h = (t.ms / max) as f32 * rect.height();
                let colour = self
                    .names
                    .iter()
                    .position(|n| *n == t.name)
                    .map_or(Color32::GRAY, Self::colour);
                let r = Rect::from_min_max(egui::pos2(x, y - h), egui::pos2(x + bar, y));
                painter.rect_filled(r, 0.0, colour);
                y -= h;
            }
        }
        painter.rect_stroke(
            rect,
            2.0,
            Stroke::new(1.0, Color32::from_gray(90)),
            egui::StrokeKind::Inside,
        );
        painter.text(
            rect.left_top() + Vec2::new(4.0, 2.0),
            egui::Align2::LEFT_TOP,
            format!("{max:.1} ms"),
            egui::FontId::monospace(10.0),
            Color32::from_gray(200),
        );
        let source = self
            .latest()
            .and_then(|f| f.first())
            .map_or("-", |t| t.source.label());
        ui.label(format!("mean of {} frames ({source})", self.frames.len()));
        egui::Grid::new("pass legend").striped(true).show(ui, |ui| {
            let mut total = 0.0;
            for t in self.means() {
                let i = self.names.iter().position(|n| *n == t.name).unwrap_or(0);
                let (swatch, _) = ui.allocate_exact_size(Vec2::splat(10.0), Sense::hover());
                ui.painter().rect_filled(swatch, 2.0, Self::colour(i));
                ui.label(&t.name);
                ui.monospace(format!("{:>8.2} ms", t.ms));
                ui.end_row();
                total += t.ms;
            }
            ui.label("");
            ui.strong("total");
            ui.monospace(format!("{total:>8.2} ms"));
            ui.end_row();
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octolux::gpu::TimingSource;

    fn pass(name: &str, ms: f64) -> PassTiming {
        PassTiming {
            name: name.into(),
            ms,
            source: TimingSource::CpuSubmitWait,
        }
    }

    #[test]
    fn keeps_the_last_frames_and_averages_them() {
        let mut h = TimingHistory::default();
        for i in 0..(HISTORY + 10) {
            h.push(vec![pass("a", i as f64), pass("b", 1.0)]);
        }
        assert_eq!(h.frames.len(), HISTORY);
        let means = h.means();
        assert_eq!(means[0].name, "a");
        // Frames 10..130 kept: mean 69.5.
        assert!((means[0].ms - 69.5).abs() < 1e-9);
        assert_eq!(means[1].ms, 1.0);
        h.clear_passes();
        assert!(h.latest().is_none());
    }

    #[test]
    fn summary_reports_first_and_last_rates() {
        let mut h = TimingHistory::default();
        assert_eq!(h.summary(), "no frames rendered");
        h.push_wall(0.5);
        h.push_wall(0.25);
        let s = h.summary();
        assert!(
            s.contains("first 1 frames 2.00 fps, last 1 frames 4.00 fps"),
            "{s}"
        );
        let mut h = TimingHistory::default();
        for _ in 0..100 {
            h.push_wall(0.1);
        }
        for _ in 0..300 {
            h.push_wall(0.2);
        }
        let s = h.summary();
        assert!(s.starts_with("400 frames in 70.0 s"), "{s}");
        assert!(s.contains("worst 200.0 ms"), "{s}");
        assert!(
            s.contains("first 100 frames 10.00 fps, last 100 frames 5.00 fps"),
            "{s}"
        );
        assert!((h.mean_wall(10).unwrap() - 0.2).abs() < 1e-6);
        assert_eq!(h.last.len(), 100);
    }
}
