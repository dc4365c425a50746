//! Who may call the service: requests must name it in their `Host` header (421 otherwise,
//! which defeats DNS rebinding: a page of another site whose name was pointed at this
//! machine still says that site's name), and with `--api-token` API routes need
//! `Authorization: Bearer <token>` (401 otherwise).

use std::{net::SocketAddr, sync::Arc};

use axum::{
    extract::{Request, State},
    http::{HeaderMap, HeaderValue, StatusCode, Uri, header, uri::Authority},
    middleware::Next,
    response::{IntoResponse, Response},
};

use crate::{
    config::{ApiToken, Config},
    connections::ConnectionInfo,
    error::ApiError,
};

/// Routes served without a token: the web page's own files (it asks for the token and sends
/// it with its API calls) and the liveness check, which orchestrators probe without
/// credentials. Everything else, unknown paths included, needs it.
pub const OPEN_ROUTES: &[&str] = &["/", "/app.js", "/style.css", "/healthz"];

/// An allowed `Host`: a name, and a port unless any port will do.
#[derive(Debug, PartialEq)]
struct AllowedHost {
    name: String,
    port: Option<u16>,
}

/// The Host check and the token of a running service.
pub struct Access {
    token: Option<ApiToken>,
    any_host: bool,
    allowed_hosts: Vec<AllowedHost>,
    /// Where requests arrive when their connection does not say (it always does when served
    /// by [`crate::connections`]).
    bind: SocketAddr,
}

impl Access {
    /// From the configuration, with the token already read; an unparsable `--allowed-hosts`
    /// entry is an error.
    pub fn new(config: &Config, token: Option<ApiToken>) -> Result<Self, String> {
        let mut allowed_hosts = Vec::new();
        let mut any_host = false;
        for entry in &config.allowed_hosts {
            let entry = entry.trim();
            if entry == "*" {
                any_host = true;
                continue;
            }
            let authority: Authority = entry
                .parse()
                .map_err(|_| format!("--allowed-hosts {entry:?} is not a host or host:port"))?;
            allowed_hosts.push(AllowedHost {
                name: authority.host().to_ascii_lowercase(),
                port: authority.port_u16(),
            });
        }
        Ok(Self {
            token,
            any_host,
            allowed_hosts,
            bind: config.bind,
        })
    }

    /// True when the service asks for a token.
    pub fn has_token(&self) -> bool {
        self.token.is_some()
    }

    /// Why `host` (a `Host` header's value) does not name this service reached at
    /// `local_addr`, or `None` when it does.
    fn misdirected(&self, host: Option<&str>, local_addr: SocketAddr) -> Option<String> {
        if self.any_host {
            return None;
        }
        let Some(host) = host else {
            return Some("the request has no Host header".to_string());
        };
        let Ok(authority) = host.parse::<Authority>() else {
            return Some(format!("Host {host:?} is not a host name"));
        };
        let name = authority.host().to_ascii_lowercase();
        let port = authority.port_u16().unwrap_or(80);
        let local_ip = local_addr.ip().to_canonical();
        let is_local_address = name
            .trim_start_matches('[')
            .trim_end_matches(']')
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.to_canonical() == local_ip);
        let names_this_address = port == local_addr.port()
            && (is_local_address || (name == "localhost" && local_ip.is_loopback()));
        let allowed = self
            .allowed_hosts
            .iter()
            .any(|a| a.name == name && a.port.is_none_or(|p| p == port));
        (!names_this_address && !allowed).then(|| {
            format!(
                "this service does not answer for Host {host:?}; it answers for {local_addr} \
                 and the names of --allowed-hosts"
            )
        })
    }

    /// Why the request's credentials are refused, or `None` when they are good (or none are
    /// needed).
    fn unauthorized(&self, path: &str, headers: &HeaderMap) -> Option<(&'static str, String)> {
        let token = self.token.as_ref()?;
        if OPEN_ROUTES.contains(&path) {
            return None;
        }
        let Some(value) = headers.get(header::AUTHORIZATION) else {
            return Some((
                "",
                "this service needs `Authorization: Bearer <token>`".to_string(),
            ));
        };
        let presented = value
            .to_str()
            .ok()
            .and_then(|v| v.split_once(' '))
            .filter(|(scheme, _)| scheme.eq_ignore_ascii_case("bearer"))
            .map(|(_, token)| token.trim());
        match presented {
            Some(presented) if token.matches(presented) => None,
            Some(_) => Some(("invalid_token", "the bearer token is wrong".to_string())),
            None => Some((
                "invalid_request",
                "the Authorization header must be `Bearer <token>`".to_string(),
            )),
        }
    }
}

/// The middleware: the Host check, then the token.
pub async fn check(State(access): State<Arc<Access>>, request: Request, next: Next) -> Response {
    let local_addr = request
        .extensions()
        .get::<ConnectionInfo>()
        .map_or(access.bind, |c| c.local_addr);
    if let Some(why) = access.misdirected(host_of(request.uri(), request.headers()), local_addr) {
        return ApiError::new(StatusCode::MISDIRECTED_REQUEST, "misdirected_request", why)
            .into_response();
    }
    if let Some((error, why)) = access.unauthorized(request.uri().path(), request.headers()) {
        let mut response =
            ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", why).into_response();
        // RFC 6750: no error attribute when no credentials came at all.
        let challenge = if error.is_empty() {
            "Bearer realm=\"gi-server\"".to_string()
        } else {
            format!("Bearer realm=\"gi-server\", error=\"{error}\"")
        };
        if let Ok(challenge) = HeaderValue::from_str(&challenge) {
            response
                .headers_mut()
                .insert(header::WWW_AUTHENTICATE, challenge);
        }
        return response;
    }
    next.run(request).await
}

/// The host a request names: its absolute URI's authority, else its `Host` header.
fn host_of<'a>(uri: &'a Uri, headers: &'a HeaderMap) -> Option<&'a str> {
    uri.authority()
        .map(Authority::as_str)
        .or_else(|| headers.get(header::HOST).and_then(|v| v.to_str().ok()))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    fn access(args: &[&str]) -> Access {
        let config = Config::parse_from([&["gi-server"], args].concat());
        Access::new(&config, config.resolve_api_token().unwrap()).unwrap()
    }

    #[test]
    fn hosts_must_name_the_address_reached_or_an_allowed_name() {
        let loopback: SocketAddr = "127.0.0.1:8080".parse().unwrap();
        let access = access(&["--allowed-hosts", "render.example.org,Lab:9000"]);
        for host in [
            "127.0.0.1:8080",
            "localhost:8080",
            "LOCALHOST:8080",
            "render.example.org",
            "render.example.org:1234",
            "lab:9000",
        ] {
            assert_eq!(access.misdirected(Some(host), loopback), None, "{host}");
        }
        for host in [
            "evil.example:8080",
            "localhost:8081",
            "127.0.0.1",
            "lab:9001",
            "127.0.0.2:8080",
            "",
        ] {
            assert!(access.misdirected(Some(host), loopback).is_some(), "{host}");
        }
        assert!(access.misdirected(None, loopback).is_some());

        let lan: SocketAddr = "192.168.1.5:8080".parse().unwrap();
        assert_eq!(access.misdirected(Some("192.168.1.5:8080"), lan), None);
        assert!(access.misdirected(Some("localhost:8080"), lan).is_some());
        let v6: SocketAddr = "[::1]:8080".parse().unwrap();
        assert_eq!(access.misdirected(Some("[::1]:8080"), v6), None);
        assert_eq!(access.misdirected(Some("localhost:8080"), v6), None);
        let mapped: SocketAddr = "[::ffff:10.0.0.7]:80".parse().unwrap();
        assert_eq!(access.misdirected(Some("10.0.0.7"), mapped), None);

        let any = self::access(&["--allowed-hosts", "*"]);
        assert_eq!(any.misdirected(Some("evil.example"), loopback), None);
    }

    #[test]
    fn api_routes_need_the_bearer_token() {
        let access = access(&["--api-token", "t0ken"]);
        let headers = |value: &str| {
            let mut headers = HeaderMap::new();
            headers.insert(header::AUTHORIZATION, value.parse().unwrap());
            headers
        };
        assert_eq!(access.unauthorized("/healthz", &HeaderMap::new()), None);
        assert_eq!(access.unauthorized("/", &HeaderMap::new()), None);
        assert_eq!(
            access
                .unauthorized("/v1/jobs", &HeaderMap::new())
                .unwrap()
                .0,
            ""
        );
        assert_eq!(
            access.unauthorized("/v1/jobs", &headers("bearer t0ken")),
            None
        );
        assert_eq!(
            access
                .unauthorized("/metrics", &headers("Bearer t0ke"))
                .unwrap()
                .0,
            "invalid_token"
        );
        assert_eq!(
            access
                .unauthorized("/metrics", &headers("Basic dDBrZW4="))
                .unwrap()
                .0,
            "invalid_request"
        );
        assert_eq!(
            self::access(&[]).unauthorized("/metrics", &HeaderMap::new()),
            None
        );
    }
}
