//! A trained agent outside training, as plain data: the observation it sees and the map
//! from its actions to inputs ([`observation`]), the frozen observation statistics that
//! standardise what it sees ([`Normalizer`]), and the exported deterministic policy
//! ([`PolicyFile`], checked on reading; [`PolicyFile::check_fits`] against a model).
//!
//! It sits below both rooms that need it: [`rl`](crate::rl) trains agents on an
//! environment that builds the same observation and applies the same action map, and
//! [`control::Policy`](crate::control::Policy) runs a policy file as a controller, so a
//! policy sees in closed loop what it saw in training. Nothing here knows seasons, weather
//! sources, controllers or burn.
//!
//! * [`observation`]: the observation's layout and names, the action scale and action map;
//! * [`normalize`]: running mean/variance of observations and the clipped standardisation;
//! * [`policy`]: the policy file;
//! * [`error`]: the error type [`AgentError`].

pub mod error;
pub mod normalize;
pub mod observation;
pub mod policy;

pub use error::AgentError;
pub use normalize::Normalizer;
pub use policy::PolicyFile;
