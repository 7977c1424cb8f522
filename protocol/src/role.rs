//! The roles of a cellsar deployment: each process is one, announces itself alive as
//! `cellsar/alive/<role>/<instance>`, and (in the secure deployment) holds that role's
//! certificate; the planner, the echo and the processor publish their status under it.

use serde::{Deserialize, Serialize};

/// A role (lowercase on the wire and in keys: `"planner"`, `"echo"`, ...). A status that
/// names any other role does not decode.
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Plans missions (`cellsar plan`).
    #[default]
    Planner,
    /// Simulates the IQ of a mission (`cellsar echo`).
    Echo,
    /// Forms and checks the images (`cellsar process`).
    Processor,
    /// Carries IQ frames between iceoryx2 and Zenoh (`cellsar bridge`).
    Bridge,
    /// Runs a mission and collects its results (`cellsar run`).
    Launcher,
    /// A Zenoh router (`cellsar router`).
    Router,
}

impl Role {
    /// Every role.
    pub const ALL: [Role; 6] = [
        Role::Planner,
        Role::Echo,
        Role::Processor,
        Role::Bridge,
        Role::Launcher,
        Role::Router,
    ];

    /// The roles of the processes `cellsar run` starts as its children, and so the roles that
    /// may run elsewhere instead (`--external`) or be given a Zenoh configuration of their own
    /// (`--child-config`): the planner, the echo, the processor and the bridge.
    pub const CHILDREN: [Role; 4] = [Role::Planner, Role::Echo, Role::Processor, Role::Bridge];

    /// Whether the role is one of [`Role::CHILDREN`].
    pub fn is_child(self) -> bool {
        Role::CHILDREN.contains(&self)
    }

    /// The role's name, as in keys and on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            Role::Planner => "planner",
            Role::Echo => "echo",
            Role::Processor => "processor",
            Role::Bridge => "bridge",
            Role::Launcher => "launcher",
            Role::Router => "router",
        }
    }
}

impl std::fmt::Display for Role {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A name that is no role.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is no role (planner, echo, processor, bridge, launcher, router)")]
pub struct UnknownRole(pub String);

impl std::str::FromStr for Role {
    type Err = UnknownRole;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Role::ALL
            .into_iter()
            .find(|r| r.as_str() == s)
            .ok_or_else(|| UnknownRole(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Every role is its name on the wire and reads back from it; another name is refused,
    /// naming it.
    #[test]
    fn roles_are_their_names_on_the_wire() {
        for r in Role::ALL {
            let json = serde_json::to_string(&r).unwrap();
            assert_eq!(json, format!("\"{r}\""));
            assert_eq!(serde_json::from_str::<Role>(&json).unwrap(), r);
            assert_eq!(r.as_str().parse::<Role>().unwrap(), r);
        }
        assert!(serde_json::from_str::<Role>("\"forge\"").is_err());
        let children: Vec<Role> = Role::ALL.into_iter().filter(|r| r.is_child()).collect();
        assert_eq!(children, Role::CHILDREN);
        assert!(!Role::Launcher.is_child() && !Role::Router.is_child());
        let e = "Echo".parse::<Role>().unwrap_err();
        assert!(e.to_string().starts_with("\"Echo\" is no role"), "{e}");
    }
}
