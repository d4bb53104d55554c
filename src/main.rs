//! The `ssskit` binary: argument parsing only; the work is in the library.

#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod cli;

fn main() {
    // After any signal clean-up under way (it ends the process itself).
    ssskit::io::exit(cli::main());
}
