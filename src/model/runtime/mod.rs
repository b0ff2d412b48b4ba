//! How a run behaves while it works, apart from what it computes: progress and
//! cancellation ([`progress`]), progress as log lines ([`progress_text`]) and giving memory back between stages ([`mem`]).

pub mod mem;
pub mod progress;
pub mod progress_text;
