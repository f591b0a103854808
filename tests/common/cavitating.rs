//! The multisine the sweep designer gave the article rig at beta 250 bar when it bounded the
//! amplitude by the motors' speed alone: 15 mm, 0.195 … 2.456 Hz on a period of 1/0.195 s
//! (13 lines). Emulated (with `--set beta_bar=250`) it drives chamber 1 to the cavitation floor.

/// Its options (`pumpcyl emulate --experiment multisine`, `pumpcyl frf --sweep multisine`).
pub const MULTISINE: [&str; 6] = [
    "--amplitude-mm",
    "15",
    "--from-hz",
    "0.1953125",
    "--to-hz",
    "2.456",
];
