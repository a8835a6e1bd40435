//! Lines to stdout and stderr that a closed pipe cannot turn into a panic: `veach info SCENE |
//! head -1` and `veach render ... 2>&1 | head -1` must still finish their work (and the render
//! still write its image), where `println!` would panic on the broken pipe.

/// Writes a line to stdout; a failed write (the reader went away) is ignored.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// Writes a line to stderr; a failed write is ignored.
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

pub(crate) use {errln, outln};
