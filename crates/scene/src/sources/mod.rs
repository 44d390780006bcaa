//! Scene sources: where a [`Scene`](crate::Scene) comes from. They build on the scene
//! model ([`crate`]), which knows none of them.
//!
//! - [`builtin`]: the built-in scenes and lamps of the paper's test cases and the analytic
//!   checks ([`Scene::builtin`](crate::Scene::builtin)).
//! - [`scenefile`]: the TOML scene-file format
//!   ([`Scene::from_toml_file`](crate::Scene::from_toml_file)); file meshes come in
//!   through its [`MeshLoader`](scenefile::MeshLoader).
//! - [`closed_forms`]: scenes with closed-form answers (CIE 171:2006 test case 5.8, the closed
//!   sphere) and their exact values.
//! - [`meshes`]: procedural meshes with light-map UVs (room, box, plane, sphere, chair, sofa),
//!   used by both.
//!
//! The `Scene` constructors live beside their sources, in `impl Scene` blocks of these
//! modules.

pub mod builtin;
pub mod closed_forms;
pub mod meshes;
pub mod scenefile;
