//! Endpoints and authentication (docs/opcua.md "Security"):
//!
//! - no user configured: one endpoint, SecurityPolicy None, anonymous only (meant for
//!   localhost);
//! - a user configured: one endpoint, Basic256Sha256 SignAndEncrypt, that user with their
//!   password only. The server's certificate and key are created on first start in the PKI
//!   folder.
//!
//! Every refused identity (a wrong password, an unknown user, an anonymous attempt on the
//! secure endpoint) is logged (`tracing` warn, user name but never the password) and counted
//! ([`RefusalLog::refused`]).

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use acc_runtime::opcua_config::{OpcUaSettings, OpcUaUser};
use opcua::crypto::SecurityPolicy;
use opcua::server::authenticator::{AuthManager, DefaultAuthenticator, Password, UserToken};
use opcua::server::{ServerBuilder, ServerEndpoint, ServerUserToken, ANONYMOUS_USER_TOKEN_ID};
use opcua::types::{Error, MessageSecurityMode, UserTokenPolicy};

/// Id of the configured user's token in the server config.
const USER_TOKEN_ID: &str = "acc-user";

/// Read the first line of `user`'s password file (a clear error when it cannot).
pub fn read_password(user: &OpcUaUser) -> Result<String, String> {
    let text = std::fs::read_to_string(&user.password_file).map_err(|e| {
        format!(
            "OPC UA user `{}`: password_file {}: {e}",
            user.name,
            user.password_file.display()
        )
    })?;
    let pw = text.lines().next().unwrap_or("").to_string();
    if pw.is_empty() {
        return Err(format!(
            "OPC UA user `{}`: password_file {} is empty",
            user.name,
            user.password_file.display()
        ));
    }
    Ok(pw)
}

/// The endpoints, users and PKI folder of `cfg` on `builder`, with `password` for the user.
pub fn secure(
    builder: ServerBuilder,
    cfg: &OpcUaSettings,
    password: Option<&str>,
    pki_dir: &Path,
    log: Arc<RefusalLog>,
) -> ServerBuilder {
    let b = builder
        .pki_dir(pki_dir)
        .trust_client_certs(cfg.trust_client_certs);
    let mut users = BTreeMap::new();
    let b = match (&cfg.user, password) {
        (Some(u), Some(pw)) => {
            let token = ServerUserToken::user_pass(u.name.as_str(), pw);
            users.insert(USER_TOKEN_ID.to_string(), token.clone());
            b.create_sample_keypair(true)
                .add_user_token(USER_TOKEN_ID, token)
                .add_endpoint(
                    "basic256sha256_sign_encrypt",
                    (
                        "/",
                        SecurityPolicy::Basic256Sha256,
                        MessageSecurityMode::SignAndEncrypt,
                        &[USER_TOKEN_ID] as &[&str],
                    ),
                )
                .default_endpoint("basic256sha256_sign_encrypt")
        }
        _ => b
            .create_sample_keypair(false)
            .add_endpoint(
                "none",
                (
                    "/",
                    SecurityPolicy::None,
                    MessageSecurityMode::None,
                    &[ANONYMOUS_USER_TOKEN_ID] as &[&str],
                ),
            )
            .default_endpoint("none"),
    };
    b.with_authenticator(Arc::new(LoggingAuth {
        inner: DefaultAuthenticator::new(users),
        log,
    }))
}

/// Refused identities, counted.
#[derive(Debug, Default)]
pub struct RefusalLog {
    refused: AtomicU64,
}

impl RefusalLog {
    /// Identities refused so far.
    pub fn refused(&self) -> u64 {
        self.refused.load(Ordering::Relaxed)
    }

    fn note(&self, what: &str, e: &Error) {
        self.refused.fetch_add(1, Ordering::Relaxed);
        tracing::warn!(identity = what, status = %e.status(), "OPC UA: identity refused");
        // The run's operator sees it on the console too (tracing may be off).
        eprintln!("telemetry: OPC UA refused {what}: {}", e.status());
    }
}

/// The crate's user table, with every refusal logged and counted.
struct LoggingAuth {
    inner: DefaultAuthenticator,
    log: Arc<RefusalLog>,
}

#[async_trait::async_trait]
impl AuthManager for LoggingAuth {
    async fn authenticate_anonymous_token(&self, endpoint: &ServerEndpoint) -> Result<(), Error> {
        let r = self.inner.authenticate_anonymous_token(endpoint).await;
        if let Err(e) = &r {
            self.log.note("an anonymous session", e);
        }
        r
    }

    async fn authenticate_username_identity_token(
        &self,
        endpoint: &ServerEndpoint,
        username: &str,
        password: &Password,
    ) -> Result<UserToken, Error> {
        let r = self
            .inner
            .authenticate_username_identity_token(endpoint, username, password)
            .await;
        if let Err(e) = &r {
            self.log.note(&format!("user `{username}`"), e);
        }
        r
    }

    fn user_token_policies(&self, endpoint: &ServerEndpoint) -> Vec<UserTokenPolicy> {
        self.inner.user_token_policies(endpoint)
    }
}
