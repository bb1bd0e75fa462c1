//! Placeholder: the JIT benchmark lands in the next commit.
fn main() {}
