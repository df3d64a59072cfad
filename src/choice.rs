//! Settings with a fixed set of named values (the back-end, the guide, the bands, MPC's
//! warm start, a solve's status, ...): each value's name, as spec files, flags, logs and
//! Python spell it, and its help, the variant's doc comment, are stated once, in the
//! [`choice!`](crate::choice!) declaration, wherever the enum lives. The command line
//! builds its parsers from [`Choice`], so the spec types need no command-line library.
//! This module uses no other: any layer may declare its settings with it.

/// A setting with a fixed set of named values.
pub trait Choice: Copy + Eq + Sized + Send + Sync + 'static {
    /// Every value, in the order help lists them.
    const ALL: &'static [Self];

    /// The name spec files, flags and Python use.
    fn name(self) -> &'static str;

    /// One paragraph of help: the value's doc comment.
    fn help(self) -> &'static str;

    /// The value called `name`.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|c| c.name() == name)
    }
}

/// Declares a [`Choice`](crate::choice::Choice) enum: each variant with its doc comment and
/// the name it is spelt by (`Ipm = "ipm"`), and after the enum `default Ipm` where it has a
/// default. Serialised by that name; `Display` writes it.
#[macro_export]
macro_rules! choice {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $( $(#[doc = $doc:literal])* $variant:ident = $text:literal ),+ $(,)?
        }
        $(default $default:ident)?
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        $vis enum $name {
            $( $(#[doc = $doc])* $variant ),+
        }

        $(
            impl Default for $name {
                fn default() -> Self {
                    $name::$default
                }
            }
        )?

        impl $name {
            /// The name spec files, flags and Python use.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text),+
                }
            }

            /// One paragraph of help: the value's doc comment.
            pub fn help(self) -> &'static str {
                match self {
                    $($name::$variant => concat!($($doc),*).trim_ascii()),+
                }
            }

            /// The value called `name`.
            pub fn from_name(name: &str) -> Option<Self> {
                <$name as $crate::choice::Choice>::from_name(name)
            }
        }

        impl $crate::choice::Choice for $name {
            const ALL: &'static [Self] = &[$($name::$variant),+];

            fn name(self) -> &'static str {
                $name::name(self)
            }

            fn help(self) -> &'static str {
                $name::help(self)
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                serializer.serialize_str(self.name())
            }
        }

        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                const NAMES: &[&str] = &[$($text),+];
                let text = <std::borrow::Cow<'de, str>>::deserialize(deserializer)?;
                <$name as $crate::choice::Choice>::from_name(&text)
                    .ok_or_else(|| serde::de::Error::unknown_variant(&text, NAMES))
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::Choice;

    crate::choice! {
        /// A test setting.
        enum Colour {
            /// Like the sky.
            ///   On two lines.
            Blue = "blue",
            /// Like grass.
            Green = "green",
        }
        default Green
    }

    #[test]
    fn a_choice_is_named_helped_and_read_back_by_its_name() {
        assert_eq!(Colour::ALL, &[Colour::Blue, Colour::Green]);
        assert_eq!(Colour::Green.name(), "green");
        assert_eq!(Colour::Blue.help(), "Like the sky.   On two lines.");
        assert_eq!(Colour::from_name("blue"), Some(Colour::Blue));
        assert_eq!(serde_json::to_string(&Colour::Green).unwrap(), "\"green\"");
        let back: Colour = serde_json::from_str("\"blue\"").unwrap();
        assert_eq!(back, Colour::Blue);
        let e = serde_json::from_str::<Colour>("\"red\"").unwrap_err();
        assert!(e.to_string().contains("expected `blue` or `green`"), "{e}");
        assert_eq!(Colour::Blue.to_string(), "blue");
        assert_eq!(Colour::default(), Colour::Green);
    }
}
