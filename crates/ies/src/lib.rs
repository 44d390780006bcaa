//! IES photometry (placeholder, filled by issue #2).
