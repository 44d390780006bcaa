//! luxbake core (being built by issue #4): scene model, light-map layout, pass graph, CPU reference.
pub mod scene;
