//! Self-contained HTML reports with hand-written inline SVG charts.
//!
//! Everything here renders to plain strings with fixed float formatting, so the same numbers always give the
//! same bytes (golden-file tests stay stable) and a report opens offline: inline CSS, no scripts, no fonts, no
//! images from anywhere.
//!
//! - [`Document`]: title, sections, paragraphs, [`Table`]s, [`Chart`] figures, a "how to read this" block.
//! - [`Chart`] with [`Series`]: line / scatter charts, optional bands (x̄ ± k·s) and error bars, nice ticks;
//!   [`points_by_run`] draws a series measured in several runs with a break between runs.
//! - [`nice_ticks`], [`escape`], [`fmt_num`]: the building blocks, public for other renderers.

mod chart;
mod document;
mod format;
mod ticks;

pub use chart::{Chart, Mark, PALETTE, Series, points_by_run};
pub use document::{Cell, Document, Table};
pub use format::{escape, fmt_num};
pub use ticks::{Ticks, nice_ticks};
