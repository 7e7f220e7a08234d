//! Property checks usable from tests and from the command line: χ² goodness of fit of
//! sampling against the pdf, reciprocity, energy conservation, sample/eval/pdf consistency,
//! and non-negativity/finiteness; [`suite`] runs them all on one material.

pub mod chi2;
pub mod lobe;
pub mod props;
pub mod stats;
pub mod suite;

pub use chi2::{chi2_test, Chi2Config, Chi2Result};
pub use lobe::{lobe_selection_test, LobeSelectionResult};
pub use props::{
    albedo, finite_nonnegative, reciprocity, reciprocity_channels, sample_consistency,
};
pub use suite::{run_suite, CheckOutcome, Reciprocity, SuiteConfig, SuiteReport, Verdict};
