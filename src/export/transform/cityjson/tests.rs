use super::*;
use crate::export::transform::citygml::edit::{BboxMode, LodMode, Lods, Subset};
use serde_json::json;

/// Two buildings: `a` (a part `a1` at LoD 1 and 2, an installation `a2` at LoD 3) near the
/// origin, `b` (LoD 2 only) at x 90..99; vertices in millimetres.
fn doc() -> Value {
    json!({"type":"CityJSON","version":"2.0",
      "transform":{"scale":[0.001,0.001,0.001],"translate":[100.0,200.0,0.0]},
      "metadata":{"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415",
                  "geographicalExtent":[0,0,0,1,1,1]},
      "CityObjects":{
        "a":{"type":"Building","attributes":{"roofType":"1000"},"children":["a1","a2"]},
        "b":{"type":"Building","geometry":[{"type":"Solid","lod":"2.2",
             "boundaries":[[[[5,6,7]]]],
             "semantics":{"surfaces":[{"type":"RoofSurface"}],"values":[[0]]}}]},
        "a1":{"type":"BuildingPart","parents":["a"],"geometry":[
             {"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]},
             {"type":"MultiSurface","lod":"2","boundaries":[[[0,1,3]]]}]},
        "a2":{"type":"BuildingInstallation","parents":["a"],"geometry":[
             {"type":"MultiSurface","lod":"3","boundaries":[[[2,3,4]]]}]}},
      "vertices":[[0,0,0],[2000,0,0],[2000,1000,3000],[0,1000,3000],[1000,500,4000],
                  [90000,0,0],[99000,9000,9000],[90000,9000,0],[500000,0,0]]})
}

fn run_on(v: &Value, name: &str, f: &dyn Fn(&Path, &Path) -> EditSummary) -> (EditSummary, Value) {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join(name);
    std::fs::write(&src, serde_json::to_vec(v).unwrap()).unwrap();
    let out = dir.path().join(format!("out-{name}"));
    let s = f(&src, &out);
    let text = std::fs::read(&out).unwrap();
    (s, serde_json::from_slice(&text).unwrap())
}

/// [`rules::subset`] of [`doc`] by `rule`: the summary and the document written.
fn subset_doc(rule: &Subset) -> (EditSummary, Value) {
    run_on(&doc(), "a.city.json", &|i, o| {
        rules::subset(i, o, rule, &Default::default()).unwrap()
    })
}

/// [`rules::filter_lods`] of [`doc`] by `rule`: the summary and the document written.
fn filter_doc(rule: &Lods) -> (EditSummary, Value) {
    run_on(&doc(), "a.city.json", &|i, o| {
        rules::filter_lods(i, o, rule, &Default::default()).unwrap()
    })
}

/// `lods` applied in `mode`, trees left empty removed.
fn lods(lods: &[u8], mode: LodMode) -> Lods {
    Lods {
        lods: lods.to_vec(),
        mode,
        keep_empty: false,
    }
}

/// The lines of the CityJSONSeq file at `path`.
fn seq_lines(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn trees_follow_children_in_document_order() {
    let d = doc();
    let t = trees(d["CityObjects"].as_object().unwrap());
    assert_eq!(t, vec![vec!["a", "a1", "a2"], vec!["b"]]);
}

#[test]
fn subset_by_box_keeps_whole_trees_renumbers_and_recomputes_the_extent() {
    let rule = Subset {
        bbox: Some([99.0, 199.0, 101.5, 201.0]),
        ..Subset::default()
    };
    let (s, out) = subset_doc(&rule);
    assert_eq!((s.members, s.members_kept), (2, 1));
    let objects = out["CityObjects"].as_object().unwrap();
    assert_eq!(objects.keys().collect::<Vec<_>>(), ["a", "a1", "a2"]);
    assert_eq!(out["CityObjects"]["a"]["attributes"]["roofType"], "1000");
    // five vertices used by the tree, renumbered in order of use; b's and the unused gone
    assert_eq!(out["vertices"].as_array().unwrap().len(), 5);
    assert_eq!(
        out["CityObjects"]["a2"]["geometry"][0]["boundaries"],
        json!([[[2, 3, 4]]])
    );
    assert_eq!(
        out["metadata"]["geographicalExtent"],
        json!([100.0, 200.0, 0.0, 102.0, 201.0, 4.0])
    );
    assert_eq!(out["transform"], doc()["transform"]);
    // the box in a named CRS: converted into the document's (here the same one)
    let named = Subset {
        bbox_crs: Some(crate::model::crs::Crs::parse("EPSG:7415")),
        ..rule.clone()
    };
    let (s, _) = subset_doc(&named);
    assert_eq!(s.members_kept, 1);
    // within: `a` reaches x 102 > 101.5, so nothing is within
    let within = Subset {
        mode: BboxMode::Within,
        ..rule.clone()
    };
    let (s, out) = subset_doc(&within);
    assert_eq!(s.members_kept, 0);
    assert!(out["metadata"].get("geographicalExtent").is_none());
    assert_eq!(out["vertices"], json!([]));
}

#[test]
fn subset_by_type_invert_and_limit() {
    let rule = Subset {
        types: vec!["Building".into()],
        invert: true,
        ..Subset::default()
    };
    let (s, _) = subset_doc(&rule);
    assert_eq!(s.members_kept, 0);
    let rule = Subset {
        limit: Some(1),
        ..Subset::default()
    };
    let (s, out) = subset_doc(&rule);
    assert_eq!(s.members_kept, 1);
    assert!(out["CityObjects"]["b"].is_null());
}

#[test]
fn filter_lods_removes_geometries_and_emptied_nested_objects() {
    let keep2 = lods(&[2], LodMode::Keep);
    let (s, out) = filter_doc(&keep2);
    // a1 keeps its LoD 2; a2 (LoD 3 only) goes with its reference in a; b's "2.2" counts as 2
    assert_eq!(s.lod_properties_removed, 2);
    assert_eq!(s.features_removed, 1);
    assert_eq!(s.references_pruned, 1);
    let o = &out["CityObjects"];
    assert!(o["a2"].is_null() && o["b"].is_object());
    assert_eq!(o["a"]["children"], json!(["a1"]));
    assert_eq!(o["a1"]["geometry"].as_array().unwrap().len(), 1);
    assert_eq!(o["a1"]["geometry"][0]["lod"], "2");
    // maximum: a keeps LoD 3 (its highest listed), b its 2
    let max = lods(&[1, 2, 3], LodMode::Maximum);
    let (_, out) = filter_doc(&max);
    let o = &out["CityObjects"];
    assert!(o["a1"].is_null() && o["a2"].is_object() && o["b"].is_object());
    // keep 0: everything emptied goes, unless --keep-empty
    let zero = lods(&[0], LodMode::Keep);
    let (s, out) = filter_doc(&zero);
    assert_eq!((s.members_kept, s.lod_properties_removed), (0, 0));
    assert_eq!(out["CityObjects"], json!({}));
    let empty = Lods {
        keep_empty: true,
        ..zero
    };
    let (s, out) = filter_doc(&empty);
    assert_eq!((s.members_kept, s.lod_properties_removed), (2, 4));
    assert_eq!(out["CityObjects"].as_object().unwrap().len(), 4);
}

/// The same document as CityJSONSeq: a header, then one feature per tree.
fn seq() -> String {
    let d = doc();
    let mut head = d.clone();
    head["CityObjects"] = json!({});
    head["vertices"] = json!([]);
    let o = &d["CityObjects"];
    let v = &d["vertices"];
    let fa = json!({"type":"CityJSONFeature","id":"a",
        "CityObjects":{"a":o["a"],"a1":o["a1"],"a2":o["a2"]},
        "vertices":[v[0],v[1],v[2],v[3],v[4]]});
    let fb = json!({"type":"CityJSONFeature","id":"b",
        "CityObjects":{"b":{"type":"Building","geometry":[{"type":"Solid","lod":"2.2",
             "boundaries":[[[[0,1,2]]]]}]}},
        "vertices":[v[5],v[6],v[7]]});
    format!("{head}\n{fa}\n{fb}\n")
}

#[test]
fn subset_of_cityjsonseq_is_streamed_feature_by_feature() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("a.city.jsonl");
    std::fs::write(&src, seq()).unwrap();
    let out = dir.path().join("b.city.jsonl");
    let rule = Subset {
        ids: vec!["b".into()],
        ..Subset::default()
    };
    let s = rules::subset(&src, &out, &rule, &Default::default()).unwrap();
    assert_eq!((s.members, s.members_kept), (2, 1));
    let lines = seq_lines(&out);
    assert_eq!(lines.len(), 2);
    assert_eq!(
        lines[0]["metadata"]["geographicalExtent"],
        json!([190.0, 200.0, 0.0, 199.0, 209.0, 9.0])
    );
    assert_eq!(lines[1]["id"], "b");
    // filter-lods on the sequence: keep 3 drops b's feature, keeps a with a2 only
    let keep3 = lods(&[3], LodMode::Keep);
    let out = dir.path().join("c.city.jsonl");
    let s = rules::filter_lods(&src, &out, &keep3, &Default::default()).unwrap();
    assert_eq!((s.members, s.members_kept, s.features_removed), (2, 1, 1));
    let lines = seq_lines(&out);
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[1]["CityObjects"]["a"]["children"], json!(["a2"]));
    assert_eq!(lines[1]["vertices"].as_array().unwrap().len(), 3);
}

#[test]
fn a_citygml_name_and_a_bad_index_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("a.city.json");
    let mut bad = doc();
    bad["CityObjects"]["b"]["geometry"][0]["boundaries"] = json!([[[[5, 6, 70]]]]);
    for (d, out, why) in [
        (doc(), "a.gml", "written as CityJSON"),
        (bad, "b.city.json", "vertex index 70 out of range"),
    ] {
        std::fs::write(&src, serde_json::to_vec(&d).unwrap()).unwrap();
        let e = rules::subset(
            &src,
            &dir.path().join(out),
            &Subset::default(),
            &Default::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains(why), "{e}");
    }
}

#[test]
fn upgrade_1_1_to_2_0_as_cjio() {
    let v11 = json!({"type":"CityJSON","version":"1.1",
      "transform":{"scale":[1.0,1.0,1.0],"translate":[0.0,0.0,0.0]},
      "extensions":{"Generic":{"url":"https://cityjson.org/extensions/download/generic.ext.json","version":"1.0"}},
      "metadata":{"pointOfContact":{"contactName":"x","address":"Main street 1"}},
      "CityObjects":{"g":{"type":"+GenericCityObject","geometry":[
        {"type":"MultiSurface","lod":"1","boundaries":[[[0,1,2]]]}]}},
      "vertices":[[0,0,0],[1,0,0],[1,1,0]]});
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("a.city.json");
    std::fs::write(&src, serde_json::to_vec(&v11).unwrap()).unwrap();
    let out = dir.path().join("b.city.json");
    let s = upgrade_cityjson(&src, &out, &Default::default()).unwrap();
    assert_eq!((s.from.as_str(), s.objects), ("1.1", 1));
    let d: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(d["version"], "2.0");
    assert_eq!(d["CityObjects"]["g"]["type"], "GenericCityObject");
    assert!(d.get("extensions").is_none());
    assert_eq!(
        d["metadata"]["pointOfContact"]["address"],
        json!({"address": "Main street 1"})
    );
    assert_eq!(d["vertices"], v11["vertices"]);
}

#[test]
fn upgrade_1_0_compresses_and_makes_lods_strings() {
    let v10 = json!({"type":"CityJSON","version":"1.0",
      "metadata":{"referenceSystem":"urn:ogc:def:crs:EPSG::7415","datasetTitle":"t","foo":1},
      "CityObjects":{"grp":{"type":"CityObjectGroup","members":["b"]},
        "b":{"type":"Building","address":{"x":1},"geometry":[
          {"type":"MultiSurface","lod":2,"boundaries":[[[0,1,2]]]}]}},
      "vertices":[[10.5,20.25,1.0],[11.5,20.25,1.0],[11.5,21.0,2.0]]});
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("a.json");
    std::fs::write(&src, serde_json::to_vec(&v10).unwrap()).unwrap();
    let out = dir.path().join("b.city.json");
    upgrade_cityjson(&src, &out, &Default::default()).unwrap();
    let d: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(d["version"], "2.0");
    assert_eq!(d["transform"]["translate"], json!([10.0, 20.0, 1.0]));
    assert_eq!(
        d["vertices"],
        json!([[500, 250, 0], [1500, 250, 0], [1500, 1000, 1000]])
    );
    assert_eq!(d["CityObjects"]["b"]["geometry"][0]["lod"], "2");
    assert_eq!(d["CityObjects"]["grp"]["children"], json!(["b"]));
    assert_eq!(d["CityObjects"]["b"]["parents"], json!(["grp"]));
    assert_eq!(d["CityObjects"]["b"]["address"], json!([{"x": 1}]));
    assert_eq!(
        d["metadata"],
        json!({"referenceSystem":"https://www.opengis.net/def/crs/EPSG/0/7415","title":"t"})
    );
}

/// [`doc`] with its top-level members in `order` (every member once).
fn reordered(order: &[&str]) -> Value {
    let d = doc();
    let m: Map<String, Value> = order
        .iter()
        .map(|k| (k.to_string(), d[*k].clone()))
        .collect();
    assert_eq!(m.len(), d.as_object().unwrap().len());
    Value::Object(m)
}

#[test]
fn a_document_streams_whatever_the_order_of_its_members() {
    // vertices before the objects, the transform after both, metadata last, ...
    let orders: [&[&str]; 4] = [
        &[
            "type",
            "version",
            "transform",
            "metadata",
            "CityObjects",
            "vertices",
        ],
        &[
            "vertices",
            "type",
            "CityObjects",
            "version",
            "metadata",
            "transform",
        ],
        &[
            "CityObjects",
            "vertices",
            "transform",
            "type",
            "metadata",
            "version",
        ],
        &[
            "metadata",
            "vertices",
            "transform",
            "version",
            "CityObjects",
            "type",
        ],
    ];
    let bbox = Subset {
        bbox: Some([99.0, 199.0, 101.5, 201.0]),
        ..Subset::default()
    };
    let keep2 = lods(&[2], LodMode::Keep);
    let run_all = |d: &Value| {
        let (s1, a) = run_on(d, "a.city.json", &|i, o| {
            rules::subset(i, o, &bbox, &Default::default()).unwrap()
        });
        let (s2, b) = run_on(d, "a.city.json", &|i, o| {
            rules::filter_lods(i, o, &keep2, &Default::default()).unwrap()
        });
        let (_, c) = run_on(d, "a.city.json", &|i, o| {
            upgrade_cityjson(i, o, &Default::default()).unwrap();
            EditSummary::default()
        });
        let counts = |s: &EditSummary| {
            (
                s.members,
                s.members_kept,
                s.lod_properties_removed,
                s.references_pruned,
            )
        };
        ((counts(&s1), a), (counts(&s2), b), c)
    };
    let want = run_all(&doc());
    // what the other tests check of the usual order holds here too
    assert_eq!((want.0).0, (2, 1, 0, 0));
    assert_eq!((want.1).0, (2, 2, 2, 1));
    assert_eq!(want.2, doc());
    for order in orders {
        let got = run_all(&reordered(order));
        assert_eq!(got, want, "{order:?}");
        // the members are written in the source's order, the objects and vertices last
        let mut keys: Vec<&str> = order
            .iter()
            .copied()
            .filter(|k| !matches!(*k, "CityObjects" | "vertices"))
            .collect();
        keys.extend(["CityObjects", "vertices"]);
        let written: Vec<&str> = (got.0)
            .1
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        assert_eq!(written, keys, "{order:?}");
    }
}

#[test]
fn a_truncated_document_and_a_bad_vertex_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("cut.city.json");
    let text = serde_json::to_string(&doc()).unwrap();
    let out = dir.path().join("out.city.json");
    // cut inside the city objects, inside the vertices, after the last member
    for cut in [
        text.find("\"a1\"").unwrap() + 10,
        text.find("[90000").unwrap() + 3,
        text.len() - 1,
    ] {
        std::fs::write(&src, &text[..cut]).unwrap();
        let errors = [
            rules::subset(&src, &out, &Subset::default(), &Default::default()).unwrap_err(),
            rules::filter_lods(&src, &out, &lods(&[2], LodMode::Keep), &Default::default())
                .unwrap_err(),
            upgrade_cityjson(&src, &out, &Default::default()).unwrap_err(),
        ];
        for e in errors {
            let e = e.to_string();
            assert!(e.contains("cut.city.json:1:"), "{e}");
            assert!(e.contains("EOF while parsing"), "{e}");
        }
        assert!(!out.exists());
    }
    // a vertex index past the end: the file, the object and the index named
    let mut bad = doc();
    bad["CityObjects"]["a2"]["geometry"][0]["boundaries"] = json!([[[2, 3, 9]]]);
    std::fs::write(&src, serde_json::to_vec(&bad).unwrap()).unwrap();
    let e = rules::subset(&src, &out, &Subset::default(), &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("cut.city.json"), "{e}");
    assert!(
        e.contains("city object a2: vertex index 9 out of range (9 vertices)"),
        "{e}"
    );
    assert!(!out.exists());
    // a city object given twice
    let text = serde_json::to_string(&doc())
        .unwrap()
        .replacen("\"b\":{", "\"a1\":{", 1);
    std::fs::write(&src, text).unwrap();
    let e = rules::subset(&src, &out, &Subset::default(), &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("city object id \"a1\" given twice"), "{e}");
}

#[test]
fn a_merge_of_documents_streams_whatever_the_order_of_their_members() {
    let dir = tempfile::tempdir().unwrap();
    let merged = |a: &Value, b: &Value| {
        let (pa, pb) = (
            dir.path().join("a.city.json"),
            dir.path().join("b.city.json"),
        );
        std::fs::write(&pa, serde_json::to_vec(a).unwrap()).unwrap();
        std::fs::write(&pb, serde_json::to_vec(b).unwrap()).unwrap();
        let out = dir.path().join("m.city.json");
        let inputs = [pa, pb];
        let s = crate::export::merge::merge_cityjson(
            &inputs,
            &inputs,
            &out,
            false,
            &Default::default(),
        )
        .unwrap();
        let v: Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();
        std::fs::remove_file(&out).unwrap();
        ((s.members, s.ids_renamed, s.refs_rewritten), v)
    };
    let want = merged(&doc(), &doc());
    // the second input's ids renamed, its vertices after the first's
    assert_eq!(want.0, (4, 4, 4));
    let objects = want.1["CityObjects"].as_object().unwrap();
    assert_eq!(objects.len(), 8);
    assert_eq!(objects["a__2"]["children"], json!(["a1__2", "a2__2"]));
    assert_eq!(
        objects["b__2"]["geometry"][0]["boundaries"],
        json!([[[[14, 15, 16]]]])
    );
    assert_eq!(want.1["vertices"].as_array().unwrap().len(), 18);
    let late = reordered(&[
        "vertices",
        "CityObjects",
        "metadata",
        "type",
        "version",
        "transform",
    ]);
    for (a, b) in [(&late, &doc()), (&doc(), &late), (&late, &late)] {
        assert_eq!(merged(a, b), want);
    }
}
