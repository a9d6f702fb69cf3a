//! SQL over the store in a build without the `store` feature: [`query_text`] says how to
//! build the query engine in.

use std::path::Path;

use crate::FleetError;

/// Always [`FleetError::NotBuilt`].
pub fn query_text(_root: &Path, _sql: &str, _csv: bool) -> Result<String, FleetError> {
    Err(FleetError::NotBuilt)
}
