//! Reports: plots of seasons and learning curves, and the atomic writing of every result
//! file ([`atomic`]), which any room that writes a file may use.
pub mod atomic;
pub mod plot;
