//! Reports: plots of seasons and learning curves, the atomic writing of every result
//! file ([`atomic`]) and CSV tables ([`table`]), which any room that writes a file may use.
pub mod atomic;
pub mod plot;
pub mod table;
