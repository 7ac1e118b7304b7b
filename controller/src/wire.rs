//! [`wire_enum!`]: an enum whose variants travel as one-byte codes (the `SessionConfig`'s
//! preset, ablation and law), defined once with its code and its name: the wire code
//! (`code`, `from_code`, `ALL` in code order, `COUNT`), the name on the command line and in
//! reports (`name`, `from_name`, serde in kebab-case), and with the `clap` feature a clap
//! value enum of the same names. As smoltcp's `enum_with_unknown!`, one macro keeps the
//! three in step; a test in `trn-node` ties the protocol's code ranges to `COUNT`.

/// Defines a wire-coded enum (see the module).
#[macro_export]
macro_rules! wire_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $code:literal => $text:literal, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        #[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
        #[serde(rename_all = "kebab-case")]
        #[repr(u8)]
        pub enum $name {
            $( $(#[$vmeta])* $variant = $code, )*
        }

        impl $name {
            /// Every variant, in wire-code order.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];
            /// The number of codes (codes are `0..COUNT`).
            pub const COUNT: u8 = $name::ALL.len() as u8;

            /// The variant of a wire code.
            pub const fn from_code(code: u8) -> Option<$name> {
                match code {
                    $( $code => Some($name::$variant), )*
                    _ => None,
                }
            }

            /// Its wire code.
            pub const fn code(self) -> u8 {
                self as u8
            }

            /// Its name on the command line and in reports.
            pub const fn name(self) -> &'static str {
                match self {
                    $( $name::$variant => $text, )*
                }
            }

            /// The variant of a name.
            pub fn from_name(name: &str) -> Option<$name> {
                $name::ALL.iter().copied().find(|v| v.name() == name)
            }
        }
    };
}
