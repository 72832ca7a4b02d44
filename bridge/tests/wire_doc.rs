//! docs/wire-protocol.md against the code: the page's tables are parsed and every documented
//! type name, size, alignment, field offset, quality-of-service value and event id is compared
//! with what the Rust types have (`size_of`, `align_of`, `offset_of!`) and with what iceoryx2
//! registered for the services Lamina opens (their static configuration). Field sizes are
//! computed from the page's own type column (`[f64; 3]` is 24 bytes), so the page is read as a
//! client would read it.

use core::time::Duration;
use std::collections::BTreeMap;

use iceoryx2::prelude::PortFactory as _;
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use lamina_bridge::services::{open_message_service, open_nodes_service, open_topology_service, open_wake_service};
use lamina_bridge::wire::TypeLayout;
use lamina_bridge::{
    Bridge, BridgeConfig, ContactFeedback, FeedbackPublisher, NodesPublisher, ServiceNames, StatsPublisher,
    StatsSummary, ToolCommand, ToolPublisher, Topology, TopologyPublisher, UserDomain,
};

fn page() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/wire-protocol.md");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// One markdown table: rows of (header cell → cell), back-quotes removed.
type Table = Vec<BTreeMap<String, String>>;

fn cells(line: &str) -> Vec<String> {
    let line = line.trim().trim_start_matches('|').trim_end_matches('|');
    line.split('|').map(|c| c.trim().replace('`', "")).collect()
}

/// The first table at or after line `from` of `text`, and the line after it.
fn table_from(lines: &[&str], from: usize) -> Option<(Table, usize)> {
    let start = (from..lines.len()).find(|&i| lines[i].trim_start().starts_with('|'))?;
    let header = cells(lines[start]);
    let mut rows = Vec::new();
    let mut i = start + 2; // header, then the |---| line
    while i < lines.len() && lines[i].trim_start().starts_with('|') {
        let row = cells(lines[i]);
        assert_eq!(row.len(), header.len(), "table row with a wrong cell count: {}", lines[i]);
        rows.push(header.iter().cloned().zip(row).collect());
        i += 1;
    }
    Some((rows, i))
}

/// Every table of the page whose header has column `column`.
fn tables_with(text: &str, column: &str) -> Vec<Table> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while let Some((table, next)) = table_from(&lines, i) {
        if table.first().is_some_and(|r| r.contains_key(column)) {
            out.push(table);
        }
        i = next;
    }
    out
}

/// The one table whose header has `column`, as rows keyed by their first column's value.
fn keyed_table(text: &str, column: &str, key: &str) -> BTreeMap<String, BTreeMap<String, String>> {
    let tables = tables_with(text, column);
    assert_eq!(tables.len(), 1, "expected one table with a '{column}' column in docs/wire-protocol.md");
    tables[0].iter().map(|r| (r[key].clone(), r.clone())).collect()
}

/// A struct section: heading `` ### `Name` (`TypeName`): N bytes, alignment A `` and its table.
#[derive(Debug)]
struct Layout {
    type_name: String,
    size: usize,
    align: usize,
    rows: Table,
}

fn layouts(text: &str) -> BTreeMap<String, Layout> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = BTreeMap::new();
    for (i, line) in lines.iter().enumerate() {
        let Some(rest) = line.strip_prefix("### `") else { continue };
        let Some((name, rest)) = rest.split_once("` (`") else { continue };
        let (type_name, rest) = rest.split_once("`): ").expect("heading: (`TypeName`): N bytes, alignment A");
        let (size, align) = rest.split_once(" bytes, alignment ").expect("heading: N bytes, alignment A");
        let (rows, _) = table_from(&lines, i + 1).expect("a layout table follows the heading");
        out.insert(
            name.to_string(),
            Layout {
                type_name: type_name.to_string(),
                size: size.trim().parse().expect("size"),
                align: align.trim().parse().expect("alignment"),
                rows,
            },
        );
    }
    out
}

/// Size of a type written as the page writes it: primitives, arrays, and the structs the page
/// lays out itself.
fn doc_type_size(ty: &str, layouts: &BTreeMap<String, Layout>) -> usize {
    let ty = ty.trim();
    if let Some(inner) = ty.strip_prefix('[').and_then(|t| t.strip_suffix(']')) {
        let (elem, n) = inner.rsplit_once(';').expect("array type [T; N]");
        return doc_type_size(elem, layouts) * n.trim().parse::<usize>().expect("array length");
    }
    match ty {
        "u8" => 1,
        "u32" | "f32" => 4,
        "u64" | "f64" => 8,
        other => layouts.get(other).unwrap_or_else(|| panic!("the page does not lay out type '{other}'")).size,
    }
}

/// Checks one documented struct against the compiler's layout of the Rust type: type name,
/// size, alignment, and each field's offset and size; the documented fields must tile the
/// struct with no gap.
fn check_layout(layouts: &BTreeMap<String, Layout>, code: &TypeLayout) {
    let name = code.name;
    let doc = layouts.get(name).unwrap_or_else(|| panic!("docs/wire-protocol.md has no section for {name}"));
    assert_eq!(doc.type_name, code.type_name, "{name}: iceoryx2 type name");
    assert_eq!(doc.size, code.size, "{name}: size");
    assert_eq!(doc.align, code.align, "{name}: alignment");
    let documented: Vec<&str> = doc.rows.iter().map(|r| r["field"].as_str()).collect();
    let fields: Vec<&str> = code.fields.iter().map(|f| f.name).collect();
    assert_eq!(documented, fields, "{name}: documented fields, in order");
    let mut next = 0;
    for (row, field) in doc.rows.iter().zip(&code.fields) {
        let doc_offset: usize = row["offset"].parse().expect("offset");
        let doc_size = doc_type_size(&row["type"], layouts);
        assert_eq!(doc_offset, field.offset, "{name}.{}: offset", field.name);
        assert_eq!(doc_size, field.size, "{name}.{}: size of {}", field.name, row["type"]);
        assert_eq!(doc_offset, next, "{name}.{}: a gap before it", field.name);
        next = doc_offset + doc_size;
    }
    assert_eq!(next, doc.size, "{name}: the fields do not fill the documented size");
}

#[test]
fn documented_byte_layouts_match_the_types_works() {
    let text = page();
    let l = layouts(&text);
    let code = lamina_bridge::wire::layouts();
    for t in &code {
        check_layout(&l, t);
    }
    assert_eq!(code.len(), 10, "wire types: {:?}", code.iter().map(|t| t.name).collect::<Vec<_>>());
    assert_eq!(l.len(), 10, "sections laid out: {:?}", l.keys().collect::<Vec<_>>());
}

fn bridge(test: &str) -> Bridge {
    Bridge::open(&BridgeConfig::with_prefix(&format!("t{}_{test}", std::process::id()))).expect("bridge opens")
}

fn check_detail(service: &str, what: &str, row: &BTreeMap<String, String>, detail: &TypeDetail) {
    let cell = |c: &str| row[&format!("{what} {c}")].as_str();
    assert_eq!(cell("type name"), detail.type_name().to_string(), "{service}: {what} type name");
    assert_eq!(cell("size").parse::<usize>().unwrap(), detail.size(), "{service}: {what} size");
    assert_eq!(cell("alignment").parse::<usize>().unwrap(), detail.alignment(), "{service}: {what} alignment");
    if what == "payload" {
        let kind = match detail.variant() {
            TypeVariant::FixedSize => "fixed",
            TypeVariant::Dynamic => "slice",
        };
        assert_eq!(cell("kind"), kind, "{service}: payload kind");
    }
}

/// The publish-subscribe settings iceoryx2 holds for a service, by the page's column names.
macro_rules! pubsub_settings {
    ($service:expr) => {{
        let c = $service.static_config();
        let d = c.message_type_details();
        let settings: BTreeMap<&str, String> = [
            ("subscriber_max_buffer_size", c.subscriber_max_buffer_size().to_string()),
            ("history_size", c.history_size().to_string()),
            ("subscriber_max_borrowed_samples", c.subscriber_max_borrowed_samples().to_string()),
            ("max_publishers", c.max_publishers().to_string()),
            ("max_subscribers", c.max_subscribers().to_string()),
            ("max_nodes", c.max_nodes().to_string()),
            ("enable_safe_overflow", c.has_safe_overflow().to_string()),
        ]
        .into();
        (settings, d.payload, d.user_header)
    }};
}

#[test]
fn documented_services_match_what_iceoryx2_registers_works() {
    let text = page();
    let types = keyed_table(&text, "payload type name", "service");
    let qos = keyed_table(&text, "subscriber_max_buffer_size", "service");
    let b = bridge("wire_doc_services");
    let mut registered = BTreeMap::new();
    let nodes = open_nodes_service(&b).unwrap();
    registered.insert("nodes", pubsub_settings!(nodes));
    let topology = open_topology_service(&b).unwrap();
    registered.insert("topology", pubsub_settings!(topology));
    let stats = open_message_service::<StatsSummary>(&b).unwrap();
    registered.insert("stats", pubsub_settings!(stats));
    let tool = open_message_service::<ToolCommand>(&b).unwrap();
    registered.insert("tool", pubsub_settings!(tool));
    let feedback = open_message_service::<ContactFeedback>(&b).unwrap();
    registered.insert("feedback", pubsub_settings!(feedback));
    let names: Vec<&str> = registered.keys().copied().collect();
    assert_eq!(types.keys().map(String::as_str).collect::<Vec<_>>(), names, "services in the type table");
    assert_eq!(qos.keys().map(String::as_str).collect::<Vec<_>>(), names, "services in the QoS table");
    for (service, (settings, payload, header)) in &registered {
        check_detail(service, "payload", &types[*service], payload);
        check_detail(service, "user header", &types[*service], header);
        let row = &qos[*service];
        assert_eq!(row.len() - 1, settings.len(), "{service}: QoS columns");
        for (column, value) in settings {
            assert_eq!(&row[*column], value, "{service}: {column}");
        }
    }
}

#[test]
fn documented_event_services_match_what_iceoryx2_registers_works() {
    let text = page();
    let events = keyed_table(&text, "max_listeners", "event service");
    let b = bridge("wire_doc_events");
    let names = b.names();
    for (service, name) in [
        ("topology", &names.topology),
        ("nodes", &names.nodes),
        ("stats", &names.stats),
        ("tool", &names.tool),
        ("feedback", &names.feedback),
    ] {
        let row = events.get(service).unwrap_or_else(|| panic!("no event row for {service}"));
        let wake = open_wake_service(&b, name).unwrap();
        let c = wake.static_config();
        assert_eq!(row["max_listeners"], c.max_listeners().to_string(), "{service}");
        assert_eq!(row["max_notifiers"], c.max_notifiers().to_string(), "{service}");
        assert_eq!(row["max_nodes"], c.max_nodes().to_string(), "{service}");
        assert_eq!(row["event_id_max_value"], c.event_id_max_value().to_string(), "{service}");
        assert!(c.deadline().is_none(), "{service}: no deadline");
        assert!(c.notifier_created_event().is_none() && c.notifier_dropped_event().is_none());
        assert!(c.notifier_dead_event().is_none());
    }
    assert_eq!(events.len(), 5);
}

/// Event ids a listener on `name` collects within a short wait after `send` ran.
fn notified(b: &Bridge, name: &iceoryx2::prelude::ServiceName, send: impl FnOnce()) -> Vec<String> {
    let wake = open_wake_service(b, name).unwrap();
    let listener = wake.listener_builder().create().unwrap();
    send();
    let mut ids = Vec::new();
    listener.timed_wait(|a| ids.push(a.id.as_value().to_string()), Duration::from_millis(50)).unwrap();
    ids
}

#[test]
fn documented_event_ids_are_the_ones_publishers_send_works() {
    let text = page();
    let events = keyed_table(&text, "event id notified", "event service");
    let b = bridge("wire_doc_event_ids");
    let names = b.names().clone();
    let nodes = NodesPublisher::create(&b, 4).unwrap();
    let mut topology = TopologyPublisher::create(&b, 16).unwrap();
    let stats = StatsPublisher::create(&b).unwrap();
    let tool = ToolPublisher::create(&b).unwrap();
    let feedback = FeedbackPublisher::create(&b).unwrap();
    let expect = |service: &str| -> Vec<String> {
        match events[service]["event id notified"].as_str() {
            "none" => vec![],
            id => vec![id.to_string()],
        }
    };
    let got = notified(&b, &names.nodes, || {
        nodes.publish_from_fn(0, 0, 0.0, 4, |_| [0.0; 3]).unwrap();
    });
    assert_eq!(got, expect("nodes"), "nodes");
    let got = notified(&b, &names.topology, || {
        topology.publish(&Topology { node_count: 3, triangles: vec![[0, 1, 2]], ..Topology::default() }).unwrap();
    });
    assert_eq!(got, expect("topology"), "topology");
    // Handing the topology to a late joiner does not notify.
    let got = notified(&b, &names.topology, || topology.serve_late_joiners().unwrap());
    assert!(got.is_empty(), "serving late joiners notified {got:?}");
    let got = notified(&b, &names.stats, || {
        stats.publish(&StatsSummary::default()).unwrap();
    });
    assert_eq!(got, expect("stats"), "stats");
    // Tool commands and feedback go out polled, as lamina-haptics and the core send them.
    let got = notified(&b, &names.tool, || {
        tool.publish_polled(&ToolCommand::default()).unwrap();
    });
    assert_eq!(got, expect("tool"), "tool");
    let got = notified(&b, &names.feedback, || {
        feedback.publish_polled(&ContactFeedback::default()).unwrap();
    });
    assert_eq!(got, expect("feedback"), "feedback");
}

#[test]
fn documented_service_names_and_domain_match_works() {
    let text = page();
    let services = keyed_table(&text, "publisher", "service");
    let names = ServiceNames::new("P").unwrap();
    let mut code: Vec<&str> = [&names.topology, &names.nodes, &names.stats, &names.tool, &names.feedback]
        .iter()
        .map(|n| n.as_str())
        .collect();
    let mut documented: Vec<String> = services.keys().map(|k| k.replace("<prefix>", "P")).collect();
    code.sort_unstable();
    documented.sort_unstable();
    assert_eq!(documented, code, "service names");
    let default = format!(
        "the services are `{0}/topology`, `{0}/nodes`, `{0}/tool`, `{0}/feedback` and\n`{0}/stats`",
        lamina_bridge::DEFAULT_PREFIX
    );
    assert!(text.contains(&default), "the page names the default prefix's services: {default}");
    // The domain: the page's rule, evaluated here, against the bridge's.
    // SAFETY: geteuid has no preconditions.
    let uid = unsafe { libc::geteuid() };
    let root = match std::env::var("LAMINA_IPC_DIR") {
        Ok(dir) if !dir.is_empty() => std::path::PathBuf::from(dir),
        _ => std::path::PathBuf::from(std::env::var("TMPDIR").unwrap_or_else(|_| "/tmp".into()))
            .join(format!("lamina-{uid}")),
    };
    let domain = UserDomain::current();
    assert_eq!(domain.root, root, "root path");
    assert_eq!(domain.file_prefix, format!("iox2_lamina_u{uid}_"));
    assert!(text.contains("`iox2_lamina_u<uid>_`"), "the page gives the file prefix");
    // iceoryx2's limit on a service name, which bounds the prefix.
    assert!(text.contains(&format!("at most {} bytes", iceoryx2::prelude::ServiceName::max_len())));
}
