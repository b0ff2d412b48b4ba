//! The edits of a CityGML document: its bytes copied with the spans of what changes
//! replaced, city object by city object, memory following the largest top-level member.

pub(crate) mod edit;
pub(crate) mod reproject;
pub(crate) mod upgrade;
