//! The errors of the plotting toolkit.

/// Errors of the report renderers.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The plotting library failed, the input is inconsistent (vector lengths
    /// differ) or the requested image size is unusable.
    #[error("plot: {0}")]
    Plot(String),
    /// Nothing to draw: no series, or no finite point in any series.
    #[error("plot: no data to draw: {0}")]
    Empty(String),
}

/// A plotting-library error as a [`ReportError::Plot`].
pub(super) fn plot_err<E: std::fmt::Display>(e: E) -> ReportError {
    ReportError::Plot(e.to_string())
}
