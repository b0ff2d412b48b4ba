//! `--jobs`: the worker threads of the commands that read or trace in parallel.

use anyhow::Context;

/// `--jobs`: how many input files are worked on at once.
#[derive(clap::Args, Debug, Clone, Copy, Default)]
pub struct JobsArgs {
    /// Worker threads: input files read or written at once, parts of one large uncompressed
    /// file read at once, POIs traced at once (default: one per core). The outputs are the
    /// same whatever the number.
    #[arg(long, short = 'j', value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
}

impl JobsArgs {
    /// Make rayon's global pool `--jobs` threads wide (for commands whose every parallel step,
    /// in the binary and in the library, should use it). Call before any parallel work; the
    /// pool is built by the first call only (later calls, e.g. `--scene-radius` then the
    /// loading, do nothing), so calling it twice is no error.
    pub fn global(&self) -> anyhow::Result<()> {
        static BUILT: std::sync::Mutex<bool> = std::sync::Mutex::new(false);
        let Some(n) = self.jobs else {
            return Ok(());
        };
        let mut built = BUILT
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !*built {
            rayon::ThreadPoolBuilder::new()
                .num_threads(usize::from(n))
                .build_global()
                .context("starting the worker threads")?;
            *built = true;
        }
        Ok(())
    }

    /// Run `f` in a thread pool of `--jobs` threads (rayon's global pool without it).
    pub fn install<T: Send>(&self, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
        match self.jobs {
            None => Ok(f()),
            Some(n) => Ok(rayon::ThreadPoolBuilder::new()
                .num_threads(usize::from(n))
                .build()
                .context("starting the worker threads")?
                .install(f)),
        }
    }
}
