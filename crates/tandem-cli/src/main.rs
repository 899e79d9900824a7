// Figures, animations and all-or-nothing outputs (self-contained; used by the commands once
// they are written). `dead_code` is allowed until then.
#[allow(dead_code)]
mod anim;
#[allow(dead_code)]
mod output;
#[allow(dead_code)]
mod plot;

fn main() {}
