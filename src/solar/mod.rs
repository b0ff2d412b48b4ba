//! Solar analysis beside the LoD pipeline: sun positions, sky view factor, sun hours.
