//! Closed sets of named values: the choices a parameter or an option takes, with the
//! names the command line, the JSON metadata and the documentation use.

/// A value from a closed set, each with a name and a one-line description.
pub trait Named: Copy + PartialEq + Sized + 'static {
    /// Every value, with its name and description, in the order to list them.
    const ALL: &'static [(Self, &'static str, &'static str)];

    /// The value's name.
    fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|c| c.0 == self)
            .expect("ALL lists every value")
            .1
    }

    /// The value with this name.
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|c| c.1 == name).map(|c| c.0)
    }
}
