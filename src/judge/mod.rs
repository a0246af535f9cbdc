//! Every rule that decides a verdict, in one room: claims of the reference works
//! ([`claims`]), agreement of a cell with a published number by the publication's own spread
//! ([`agreement`]), the fidelity scoreboard's MATCH / TREND / DISAGREE / MISSING
//! ([`scoreboard`]), `slamlab diff`'s per-metric verdict ([`change`]), and the looks of a
//! sequential study ([`sequential`]). Fed by `store/`, read
//! by `report/` (which only formats) and `diff/`; built on the tests of [`crate::stats`].

pub mod agreement;
pub mod change;
pub mod claims;
pub mod margins;
pub mod scoreboard;
pub mod sensitivity;
pub mod sequential;
