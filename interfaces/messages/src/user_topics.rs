//! Topics a graph declares beyond the table (`[[topic]]` in `graph.toml`): a name of the
//! user's and a message type of the catalogue, with the [`crate::topics::USER`] QoS.
//! Declared once per process (by the graph as it is loaded), then found by
//! [`crate::topics::info`] and [`crate::topics::visit`] like the table's own, so ports,
//! the recorder and replay handle them without knowing they are the user's.
//!
//! Knows names and types; not who publishes them.

use crate::topics::{ALL, TopicInfo, USER};
use std::sync::{Mutex, PoisonError};

static DECLARED: Mutex<Vec<TopicInfo>> = Mutex::new(Vec::new());

/// Longest user topic name (iceoryx2 service names are bounded; this leaves room).
pub const MAX_USER_TOPIC: usize = 64;

/// Declares the topic `name` carrying the catalogue message `type_name`; the same
/// declaration again is a no-op. `Err` says why not: a malformed name, a name of the
/// table, a type no table topic carries, or the name declared with another type.
pub fn declare(name: &str, type_name: &str) -> Result<TopicInfo, String> {
    let well_formed = !name.is_empty()
        && name.len() <= MAX_USER_TOPIC
        && name.starts_with(|c: char| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || "_/".contains(c))
        && !name.ends_with('/')
        && !name.contains("//");
    if !well_formed {
        return Err(format!(
            "`{name}` is not a topic name: 1 to {MAX_USER_TOPIC} characters a-z, 0-9, _ and /, \
             starting with a letter"
        ));
    }
    if name.starts_with("aisle/") || ALL.iter().any(|t| t.name == name) {
        return Err(format!(
            "`{name}` is a built-in topic name (aisle/...): choose another"
        ));
    }
    let Some(carrier) = ALL.iter().find(|t| t.type_name == type_name) else {
        let mut types: Vec<&str> = ALL.iter().map(|t| t.type_name).collect();
        types.sort_unstable();
        types.dedup();
        return Err(format!(
            "no message type `{type_name}`; types are {}",
            types.join(", ")
        ));
    };
    let mut declared = DECLARED.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(t) = declared.iter().find(|t| t.name == name) {
        return if t.type_name == type_name {
            Ok(*t)
        } else {
            Err(format!("`{name}` is already declared as `{}`", t.type_name))
        };
    }
    let info = TopicInfo {
        // Leaked once per distinct topic, so names stay `&'static` like the table's.
        name: Box::leak(name.to_owned().into_boxed_str()),
        qos: USER,
        ..*carrier
    };
    declared.push(info);
    Ok(info)
}

/// The user topic called `name`, if this process declared one.
pub fn find(name: &str) -> Option<TopicInfo> {
    let declared = DECLARED.lock().unwrap_or_else(PoisonError::into_inner);
    declared.iter().find(|t| t.name == name).copied()
}

/// Every user topic declared in this process, in declaration order.
pub fn declared() -> Vec<TopicInfo> {
    DECLARED
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_user_topic_carries_a_catalogue_type_under_a_name_of_its_own() {
        let t = declare("user/pose_test", crate::RobotState::TYPE_NAME).unwrap();
        assert_eq!(t.size, std::mem::size_of::<crate::RobotState>());
        assert_eq!(crate::topics::info("user/pose_test"), Some(t));
        assert!(crate::topics::all().contains(&t));
        assert_eq!(
            declare("user/pose_test", crate::RobotState::TYPE_NAME),
            Ok(t)
        );
        for (name, ty, says) in [
            ("user/pose_test", crate::Tick::TYPE_NAME, "already declared"),
            ("aisle/tick", crate::Tick::TYPE_NAME, "built-in topic"),
            ("User/x", crate::Tick::TYPE_NAME, "not a topic name"),
            ("user/x", "aisle.Nothing.v1", "no message type"),
        ] {
            assert!(declare(name, ty).unwrap_err().contains(says), "{name}");
        }
    }
}
