//! `cellsar certs`: a test certificate authority, the router's certificate and one client
//! certificate per role for a deployment with mutual TLS (`pipeline/deploy/tls/`).
//!
//! Into one directory it writes `ca.pem` and `ca.key` (the deployment's CA), and for every role
//! `<role>.pem` and `<role>.key`: a certificate signed by the CA whose common name is the role
//! (the router's access control matches it, `cert_common_names`). The router's certificate
//! ([`ROUTER_ROLE`]) is a server certificate only (extended key usage serverAuth) and names the
//! `--host` names and addresses, which a client checks against the address it connects to;
//! these must be names no public certificate authority may certify
//! ([`bridge::zconfig::is_private_name`]: cellsar's TLS link trusts only the deployment's CA,
//! but a client on upstream Zenoh's link also trusts the public Web PKI roots, and then the
//! name is what keeps a publicly trusted certificate out). Every other role's
//! certificate is a client certificate only (clientAuth, no host names): a stolen role key
//! cannot serve as the router. Keys are ECDSA P-256, PKCS#8 PEM, mode 0600. Every file is
//! written atomically (a unique temporary file, synced, renamed), and nothing is written when
//! one of the files exists already, unless `--force`.
//!
//! `--role` takes roles only ([`Role`], the router's included), so that a misspelt role is
//! refused rather than certified under a name the access control never matches; a
//! certificate for a common name that is no role (a client the router must deny everything
//! to, as the tests' `stranger`) is asked for explicitly with `--extra-name`.

use std::fs::{File, Permissions};
use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use crate::protocol::Role;
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};

/// The roles `cellsar certs` makes certificates for by default: the router and every process
/// of the pipeline (`launcher` is `cellsar run`, the collector of the results).
pub const DEFAULT_ROLES: [Role; 6] = [
    Role::Router,
    Role::Planner,
    Role::Echo,
    Role::Processor,
    Role::Bridge,
    Role::Launcher,
];

/// The role whose certificate is the router's: a server certificate for the `--host` names.
pub const ROUTER_ROLE: Role = Role::Router;

/// The host names of the router's certificate when no `--host` is given.
pub const DEFAULT_HOSTS: [&str; 2] = ["localhost", "127.0.0.1"];

/// Longest validity accepted, days (10 years).
pub const MAX_DAYS: u32 = 3650;

/// Flags of `cellsar certs`.
#[derive(clap::Args, Debug, Clone, PartialEq, Eq)]
pub struct CertsArgs {
    /// Directory to write into (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// A role to make a certificate for (its common name; repeatable)
    /// [default: router, planner, echo, processor, bridge, launcher].
    #[arg(long = "role", value_name = "ROLE", value_parser = crate::args::role_parser(&Role::ALL))]
    pub roles: Vec<Role>,
    /// Also a client certificate whose common name is NAME, no role (repeatable): an identity
    /// the access control of `pipeline/deploy/tls/router.json5` matches to no subject, so the
    /// router denies it everything (e.g. to test that); the roles are made as without it.
    #[arg(long = "extra-name", value_name = "NAME")]
    pub extra_names: Vec<String>,
    /// A host name or IP address of the router's certificate (repeatable): the address or
    /// name clients connect to, one no public CA may certify (a private, loopback or
    /// link-local address, or a name under .internal, .localhost, .test, .local or
    /// .home.arpa) [default: localhost, 127.0.0.1].
    #[arg(long = "host", value_name = "NAME_OR_IP")]
    pub hosts: Vec<String>,
    /// Days the certificates are valid.
    #[arg(long, default_value_t = 365)]
    pub days: u32,
    /// Replace files that exist already.
    #[arg(long)]
    pub force: bool,
}

/// Why `cellsar certs` made nothing. A variant whose message includes its cause does not also
/// return it from `source()` (each cause is printed once).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CertsError {
    /// A flag out of range or malformed; names the flag.
    #[error("{flag} {value:?}: {reason}")]
    Flag {
        /// The flag.
        flag: &'static str,
        /// The value given.
        value: String,
        /// What it needs.
        reason: String,
    },
    /// A file of the set exists and `--force` was not given.
    #[error("{0} exists; give --force to replace the certificates in its directory")]
    Exists(PathBuf),
    /// Reading or writing a file failed.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The cause (in the message).
        error: std::io::Error,
    },
    /// Making a key or a certificate failed.
    #[error("making the {what}: {error}")]
    Cert {
        /// Which certificate.
        what: String,
        /// The cause (in the message).
        error: rcgen::Error,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> CertsError + '_ {
    move |error| CertsError::Io {
        path: path.to_path_buf(),
        error,
    }
}

/// One file of the set: its name, contents and mode.
struct Output {
    name: String,
    text: String,
    mode: u32,
}

/// The common names to certify: the roles (the default set when none is given), each given
/// once, then the extra names, each a key chunk (the common name the ACL matches, and a file
/// name), neither a role's name nor the CA's file name, and given once.
fn common_names(args: &CertsArgs) -> Result<Vec<String>, CertsError> {
    let roles: &[Role] = if args.roles.is_empty() {
        &DEFAULT_ROLES
    } else {
        &args.roles
    };
    let mut out: Vec<String> = Vec::new();
    for r in roles {
        if out.iter().any(|o| o == r.as_str()) {
            return Err(CertsError::Flag {
                flag: "--role",
                value: r.to_string(),
                reason: "given twice".into(),
            });
        }
        out.push(r.to_string());
    }
    for n in &args.extra_names {
        let bad = |reason: String| CertsError::Flag {
            flag: "--extra-name",
            value: n.clone(),
            reason,
        };
        bridge::keys::chunk("extra name", n).map_err(|e| bad(e.reason.to_string()))?;
        if n.parse::<Role>().is_ok() {
            return Err(bad(format!("is a role: give --role {n}")));
        }
        if n == "ca" {
            return Err(bad("is the CA's file name".into()));
        }
        if out.contains(n) {
            return Err(bad("given twice".into()));
        }
        out.push(n.clone());
    }
    Ok(out)
}

fn validity(days: u32) -> Result<(time::OffsetDateTime, time::OffsetDateTime), CertsError> {
    if !(1..=MAX_DAYS).contains(&days) {
        return Err(CertsError::Flag {
            flag: "--days",
            value: days.to_string(),
            reason: format!("must be in 1..={MAX_DAYS}"),
        });
    }
    let now = time::OffsetDateTime::now_utc();
    // an hour back, for clocks of the hosts that differ a little
    Ok((
        now - time::Duration::hours(1),
        now + time::Duration::days(i64::from(days)),
    ))
}

/// The router's host names: the `--host` values (or the defaults), each a name no public CA
/// may certify.
fn router_hosts(args: &CertsArgs) -> Result<Vec<String>, CertsError> {
    let hosts: Vec<String> = if args.hosts.is_empty() {
        DEFAULT_HOSTS.iter().map(|h| h.to_string()).collect()
    } else {
        args.hosts.clone()
    };
    if let Some(h) = hosts.iter().find(|h| !bridge::zconfig::is_private_name(h)) {
        return Err(CertsError::Flag {
            flag: "--host",
            value: h.clone(),
            reason: format!(
                "a public certificate authority may certify this name, and a client on \
                 upstream Zenoh's TLS link trusts the public roots besides the deployment's CA \
                 (cellsar's does not); give the router a private \
                 address (10/8, 172.16/12, 192.168/16, loopback) or a name under one of .{}",
                bridge::zconfig::PRIVATE_DNS_SUFFIXES.join(", .")
            ),
        });
    }
    Ok(hosts)
}

/// The parameters of the certificate of common name `role`: the router's a server certificate
/// for `hosts`, every other one a client certificate without host names.
fn leaf_params(
    role: &str,
    hosts: &[String],
    validity: (time::OffsetDateTime, time::OffsetDateTime),
) -> Result<CertificateParams, CertsError> {
    let router = role == ROUTER_ROLE.as_str();
    let names = if router { hosts.to_vec() } else { Vec::new() };
    let mut p = CertificateParams::new(names).map_err(|e| CertsError::Flag {
        flag: "--host",
        value: hosts.join(","),
        reason: e.to_string(),
    })?;
    p.distinguished_name.push(DnType::CommonName, role);
    p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    // the router serves, every other role is only ever a client of it: a role's key cannot
    // stand in for the router (a client refuses a server certificate without serverAuth)
    p.extended_key_usages = vec![if router {
        ExtendedKeyUsagePurpose::ServerAuth
    } else {
        ExtendedKeyUsagePurpose::ClientAuth
    }];
    (p.not_before, p.not_after) = validity;
    Ok(p)
}

/// Makes the CA and every role's certificate and key in memory (nothing written yet).
fn make_all(args: &CertsArgs) -> Result<Vec<Output>, CertsError> {
    let roles = common_names(args)?;
    let validity = validity(args.days)?;
    let hosts = router_hosts(args)?;
    let cert_err = |what: &str| {
        let what = what.to_string();
        move |error| CertsError::Cert { what, error }
    };
    let ca_key = KeyPair::generate().map_err(cert_err("CA key"))?;
    let mut ca = CertificateParams::default();
    ca.distinguished_name
        .push(DnType::CommonName, "cellsar deployment CA");
    ca.is_ca = IsCa::Ca(BasicConstraints::Constrained(0));
    ca.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    (ca.not_before, ca.not_after) = validity;
    let ca_cert = ca
        .self_signed(&ca_key)
        .map_err(cert_err("CA certificate"))?;
    let mut out = vec![
        Output {
            name: "ca.pem".into(),
            text: ca_cert.pem(),
            mode: 0o644,
        },
        Output {
            name: "ca.key".into(),
            text: ca_key.serialize_pem(),
            mode: 0o600,
        },
    ];
    let issuer = Issuer::new(ca, ca_key);
    for role in roles {
        let p = leaf_params(&role, &hosts, validity)?;
        let what = format!("certificate of {role}");
        let key = KeyPair::generate().map_err(cert_err(&what))?;
        let cert = p.signed_by(&key, &issuer).map_err(cert_err(&what))?;
        out.push(Output {
            name: format!("{role}.pem"),
            text: cert.pem(),
            mode: 0o644,
        });
        out.push(Output {
            name: format!("{role}.key"),
            text: key.serialize_pem(),
            mode: 0o600,
        });
    }
    Ok(out)
}

/// Writes `text` to `path` atomically with `mode`: a unique temporary file in the same
/// directory, created with `mode` (a key is never readable by others, not even for a moment),
/// synced, renamed over `path` (or, without `replace`, linked to `path` only if no file is
/// there).
fn write_file(path: &Path, text: &str, mode: u32, replace: bool) -> Result<(), CertsError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tmp = tempfile::Builder::new()
        .prefix(".cellsar-certs.")
        .suffix(".tmp")
        .permissions(Permissions::from_mode(mode))
        .tempfile_in(dir)
        .map_err(io(path))?;
    tmp.write_all(text.as_bytes())
        .and_then(|()| tmp.as_file().sync_all())
        .map_err(io(path))?;
    let persisted = if replace {
        tmp.persist(path).map(drop)
    } else {
        tmp.persist_noclobber(path).map(drop)
    };
    persisted.map_err(|e| {
        if e.error.kind() == std::io::ErrorKind::AlreadyExists {
            CertsError::Exists(path.to_path_buf())
        } else {
            io(path)(e.error)
        }
    })
}

/// Makes the CA and the roles' certificates of `args` in `args.out`; the paths written, in
/// order (`ca.pem`, `ca.key`, then `<role>.pem`, `<role>.key` for each role).
pub fn make_certs(args: &CertsArgs) -> Result<Vec<PathBuf>, CertsError> {
    let files = make_all(args)?;
    std::fs::create_dir_all(&args.out).map_err(io(&args.out))?;
    if !args.force {
        for f in &files {
            let p = args.out.join(&f.name);
            if p.symlink_metadata().is_ok() {
                return Err(CertsError::Exists(p));
            }
        }
    }
    let mut written = Vec::new();
    for f in &files {
        let p = args.out.join(&f.name);
        write_file(&p, &f.text, f.mode, args.force)?;
        written.push(p);
    }
    File::open(&args.out)
        .and_then(|d| d.sync_all())
        .map_err(io(&args.out))?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustls_pki_types::pem::PemObject;
    use rustls_pki_types::{CertificateDer, ServerName, UnixTime};

    fn args(dir: &Path) -> CertsArgs {
        CertsArgs {
            out: dir.to_path_buf(),
            roles: vec![Role::Router, Role::Echo],
            extra_names: vec![],
            hosts: vec!["10.0.0.1".into(), "router.cellsar.internal".into()],
            days: 30,
            force: false,
        }
    }

    fn der(path: &Path) -> CertificateDer<'static> {
        CertificateDer::from_pem_file(path).unwrap()
    }

    /// `leaf` verified against `anchor` for `usage` (at most one intermediate: none here).
    fn verify(
        leaf: &CertificateDer<'_>,
        anchor: &rustls_pki_types::TrustAnchor<'_>,
        usage: webpki::KeyUsage,
    ) -> Result<(), webpki::Error> {
        let ee = webpki::EndEntityCert::try_from(leaf).unwrap();
        ee.verify_for_usage(
            webpki::ALL_VERIFICATION_ALGS,
            std::slice::from_ref(anchor),
            &[],
            UnixTime::now(),
            usage,
            None,
            None,
        )
        .map(drop)
    }

    /// The router's certificate chains to the CA as a server and names the hosts asked for
    /// (and no other); every other role's chains as a client only (no serverAuth: a client
    /// refuses it as the router) and names no host; each names its role as common name; a
    /// certificate of another CA does not chain.
    #[test]
    fn the_router_serves_and_the_roles_are_clients_of_the_ca() {
        let dir = tempfile::tempdir().unwrap();
        let written = make_certs(&args(dir.path())).unwrap();
        let names: Vec<String> = written
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "ca.pem",
                "ca.key",
                "router.pem",
                "router.key",
                "echo.pem",
                "echo.key"
            ]
        );
        let ca = der(&dir.path().join("ca.pem"));
        let anchor = webpki::anchor_from_trusted_cert(&ca).unwrap();
        let router = der(&dir.path().join("router.pem"));
        let echo = der(&dir.path().join("echo.pem"));
        verify(&router, &anchor, webpki::KeyUsage::server_auth()).unwrap();
        let no_eku = |r: Result<(), webpki::Error>| {
            matches!(r, Err(webpki::Error::RequiredEkuNotFoundContext(_)))
        };
        assert!(no_eku(verify(
            &router,
            &anchor,
            webpki::KeyUsage::client_auth()
        )));
        verify(&echo, &anchor, webpki::KeyUsage::client_auth()).unwrap();
        assert!(no_eku(verify(
            &echo,
            &anchor,
            webpki::KeyUsage::server_auth()
        )));
        let valid_for = |leaf: &CertificateDer<'_>, name: &str| {
            let ee = webpki::EndEntityCert::try_from(leaf).unwrap();
            ee.verify_is_valid_for_subject_name(&ServerName::try_from(name).unwrap())
                .is_ok()
        };
        for ok in ["10.0.0.1", "router.cellsar.internal"] {
            assert!(valid_for(&router, ok), "router {ok}");
            assert!(!valid_for(&echo, ok), "echo {ok}");
        }
        for bad in ["10.0.0.2", "localhost", "other.internal"] {
            assert!(!valid_for(&router, bad), "{bad}");
        }
        for role in ["router", "echo"] {
            let leaf = der(&dir.path().join(format!("{role}.pem")));
            let (_, x) = x509_parser::parse_x509_certificate(&leaf).unwrap();
            let cns: Vec<&str> = x
                .subject()
                .iter_common_name()
                .map(|c| c.as_str().unwrap())
                .collect();
            assert_eq!(cns, [role]);
            let issuer: Vec<&str> = x
                .issuer()
                .iter_common_name()
                .map(|c| c.as_str().unwrap())
                .collect();
            assert_eq!(issuer, ["cellsar deployment CA"]);
            let days =
                (x.validity().not_after.timestamp() - x.validity().not_before.timestamp()) / 86_400;
            assert_eq!(days, 30, "{role}");
            let san = x.subject_alternative_name().unwrap();
            assert_eq!(san.is_some(), role == "router", "{role}");
        }
        // another CA's certificates do not chain to this one
        let other = tempfile::tempdir().unwrap();
        make_certs(&args(other.path())).unwrap();
        for (role, usage) in [
            ("echo", webpki::KeyUsage::client_auth()),
            ("router", webpki::KeyUsage::server_auth()),
        ] {
            let stranger = der(&other.path().join(format!("{role}.pem")));
            // the same issuer name, another key: the signature does not verify
            let r = verify(&stranger, &anchor, usage);
            assert_eq!(
                r,
                Err(webpki::Error::InvalidSignatureForPublicKey),
                "{role}"
            );
        }
    }

    /// Keys are 0600, certificates 0644; no temporary file is left; an existing set is kept
    /// (every byte) unless --force, which replaces it with a new CA.
    #[test]
    fn keys_are_private_and_nothing_is_overwritten_without_force() {
        let dir = tempfile::tempdir().unwrap();
        let a = args(dir.path());
        make_certs(&a).unwrap();
        let mode = |n: &str| {
            std::fs::metadata(dir.path().join(n))
                .unwrap()
                .permissions()
                .mode()
                & 0o777
        };
        for n in ["ca.key", "router.key", "echo.key"] {
            assert_eq!(mode(n), 0o600, "{n}");
        }
        for n in ["ca.pem", "router.pem", "echo.pem"] {
            assert_eq!(mode(n), 0o644, "{n}");
        }
        let listing = || {
            let mut v: Vec<String> = std::fs::read_dir(dir.path())
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            v.sort();
            v
        };
        assert_eq!(listing().len(), 6, "{:?}", listing());
        let ca_before = std::fs::read(dir.path().join("ca.pem")).unwrap();
        // one file of the set exists: nothing is written
        let mut b = a.clone();
        b.roles = vec![Role::Planner, Role::Echo];
        let e = make_certs(&b).unwrap_err();
        assert!(matches!(e, CertsError::Exists(_)), "{e}");
        assert!(e.to_string().contains("--force"), "{e}");
        assert!(!dir.path().join("planner.pem").exists());
        assert_eq!(std::fs::read(dir.path().join("ca.pem")).unwrap(), ca_before);
        b.force = true;
        make_certs(&b).unwrap();
        assert_ne!(std::fs::read(dir.path().join("ca.pem")).unwrap(), ca_before);
        assert_eq!(mode("planner.key"), 0o600);
        assert_eq!(listing().len(), 8, "{:?}", listing());
    }

    #[test]
    fn bad_flags_are_named() {
        let dir = tempfile::tempdir().unwrap();
        use Role::{Echo, Router};
        for (roles, extra, hosts, days, flag) in [
            (
                vec![Echo, Echo],
                vec![],
                vec![],
                1,
                "--role \"echo\": given twice",
            ),
            (vec![Echo], vec!["a/b"], vec![], 1, "--extra-name \"a/b\""),
            (vec![Echo], vec!["ca"], vec![], 1, "--extra-name \"ca\""),
            (
                vec![],
                vec!["echo"],
                vec![],
                1,
                "--extra-name \"echo\": is a role",
            ),
            (
                vec![],
                vec!["router"],
                vec![],
                1,
                "--extra-name \"router\": is a role",
            ),
            (
                vec![Echo],
                vec!["x", "x"],
                vec![],
                1,
                "--extra-name \"x\": given twice",
            ),
            (vec![Echo], vec![], vec![], 0, "--days"),
            (vec![Echo], vec![], vec![], MAX_DAYS + 1, "--days"),
            (
                vec![Router],
                vec![],
                vec!["8.8.8.8"],
                1,
                "--host \"8.8.8.8\": a public",
            ),
            (vec![Echo], vec![], vec!["router.example.com"], 1, "--host"),
            (
                vec![Router],
                vec![],
                vec!["10.0.0.1", "[2001:db8::1]"],
                1,
                "--host",
            ),
        ] {
            let a = CertsArgs {
                out: dir.path().join("x"),
                roles,
                extra_names: extra.into_iter().map(String::from).collect(),
                hosts: hosts.into_iter().map(String::from).collect(),
                days,
                force: false,
            };
            let e = make_certs(&a).unwrap_err().to_string();
            assert!(e.starts_with(flag), "{e}");
        }
        assert!(!dir.path().join("x").exists());
    }

    #[test]
    fn default_roles_and_hosts() {
        let dir = tempfile::tempdir().unwrap();
        let a = CertsArgs {
            out: dir.path().join("certs"),
            roles: vec![],
            extra_names: vec![],
            hosts: vec![],
            days: 1,
            force: false,
        };
        let written = make_certs(&a).unwrap();
        assert_eq!(written.len(), 2 + 2 * DEFAULT_ROLES.len());
        let router = der(&a.out.join("router.pem"));
        let ee = webpki::EndEntityCert::try_from(&router).unwrap();
        for h in DEFAULT_HOSTS {
            ee.verify_is_valid_for_subject_name(&ServerName::try_from(h).unwrap())
                .unwrap();
        }
        let launcher = der(&a.out.join("launcher.pem"));
        let ee = webpki::EndEntityCert::try_from(&launcher).unwrap();
        for h in DEFAULT_HOSTS {
            assert!(ee
                .verify_is_valid_for_subject_name(&ServerName::try_from(h).unwrap())
                .is_err());
        }
    }

    /// An extra name is a client certificate of the CA whose common name is that name (no
    /// host name, no server use), made besides the default roles; the roles' flag parses the
    /// roles only (`cellsar certs --role stranger` is refused by clap, naming the roles).
    #[test]
    fn extra_names_are_client_certificates_besides_the_roles() {
        let dir = tempfile::tempdir().unwrap();
        let a = CertsArgs {
            out: dir.path().join("certs"),
            roles: vec![],
            extra_names: vec!["stranger".into()],
            hosts: vec![],
            days: 1,
            force: false,
        };
        let written = make_certs(&a).unwrap();
        assert_eq!(written.len(), 2 + 2 * (DEFAULT_ROLES.len() + 1));
        let ca = der(&a.out.join("ca.pem"));
        let anchor = webpki::anchor_from_trusted_cert(&ca).unwrap();
        let leaf = der(&a.out.join("stranger.pem"));
        verify(&leaf, &anchor, webpki::KeyUsage::client_auth()).unwrap();
        assert!(verify(&leaf, &anchor, webpki::KeyUsage::server_auth()).is_err());
        let (_, x) = x509_parser::parse_x509_certificate(&leaf).unwrap();
        let cns: Vec<&str> = x
            .subject()
            .iter_common_name()
            .map(|c| c.as_str().unwrap())
            .collect();
        assert_eq!(cns, ["stranger"]);
        assert!(x.subject_alternative_name().unwrap().is_none());
        for r in DEFAULT_ROLES {
            assert!(a.out.join(format!("{r}.pem")).is_file(), "{r}");
        }
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            certs: CertsArgs,
        }
        use clap::Parser as _;
        let e = Cli::try_parse_from(["certs", "--out", "x", "--role", "stranger"])
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("--role")
                && e.contains("planner, echo, processor, bridge, launcher, router"),
            "{e}"
        );
        let c = Cli::try_parse_from(["certs", "--out", "x", "--role", "router", "--role", "echo"])
            .unwrap();
        assert_eq!(c.certs.roles, [Role::Router, Role::Echo]);
    }
}
