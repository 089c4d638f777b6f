//! `caustic serve`: the render server of the Rendered viewport (`crate::server`).

use super::args::ServeArgs;
use crate::error::Result;

/// Runs the server on stdin/stdout until `quit` or the end of the input.
pub fn run_serve(args: &ServeArgs) -> Result<()> {
    if args.threads == Some(0) {
        return Err(crate::error::Error::Usage("--threads must be at least 1".into()));
    }
    crate::server::run(args.threads, args.memory_limit.as_deref())
}
