//! The `ssskit` binary: argument parsing only; the work is in the library.

#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod cli;

fn main() {
    std::process::exit(cli::main());
}
