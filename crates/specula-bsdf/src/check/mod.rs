//! Property checks usable from tests and from the command line: χ² goodness of fit of
//! sampling against the pdf, reciprocity, energy conservation, sample/eval/pdf consistency,
//! and non-negativity/finiteness.

pub mod chi2;
pub mod props;
pub mod stats;

pub use chi2::{chi2_test, Chi2Config, Chi2Result};
pub use props::{albedo, finite_nonnegative, reciprocity, sample_consistency};
