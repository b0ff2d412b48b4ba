//! How a run behaves while it works, apart from what it computes: progress and
//! cancellation ([`progress`]), progress as log lines ([`progress_text`]), giving memory back
//! between stages ([`mem`]) and the memory a run may still take ([`available`]).

pub(crate) mod available;
pub(crate) mod mem;
pub(crate) mod progress;
pub(crate) mod progress_text;
