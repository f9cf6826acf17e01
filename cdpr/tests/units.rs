//! The library's own pieces, each alone: the trajectory law, the workspace
//! grid and its argument parsing, the robot shapes' dispatch, the pose
//! table's reading. (Here rather than in `src/`: the library's test build
//! would compile its every robot shape a second time.)

mod trajectory {
    use cdpr::trajectory::*;

    #[test]
    fn samples_rest_at_waypoints() {
        let w =
            Waypoints::new(vec![0.0, 1.0, 3.0], vec![vec![0.0, 0.0], vec![1.0, 2.0], vec![1.0, 0.0]], None)
                .unwrap();
        let times = w.sample_times(10.0).unwrap();
        assert_eq!(times.len(), 31);
        assert_eq!(*times.last().unwrap(), 3.0);
        for (t, p) in [(0.0, [0.0, 0.0]), (1.0, [1.0, 2.0]), (3.0, [1.0, 0.0])] {
            let s = w.sample(t);
            assert_eq!(s.pose, p.to_vec());
            assert!(s.velocity.iter().all(|v| v.abs() < 1e-12));
        }
        let mid = w.sample(2.0);
        assert!((mid.pose[1] - 1.0).abs() < 1e-12);
        // Peak speed of the law is 35/16 times the mean speed.
        assert!((mid.velocity[1] + 2.0 / 2.0 * 35.0 / 16.0).abs() < 1e-12);
    }
}

mod workspace {
    use cdpr::workspace::*;
    use tension_core::RobotKind;

    #[test]
    fn grid_cells_cover_the_box() {
        let g = Grid::new([0.0, 0.0, 0.0], [3.0, 2.0, 0.0], 0.5, 2);
        assert_eq!(g.n, [6, 4, 1]);
        assert_eq!(g.cells(), 24);
        assert!((g.cell_measure() - 0.25).abs() < 1e-15);
        assert!((g.measure() - 6.0).abs() < 1e-15);
        assert!((g.centre(0, 0) - 0.25).abs() < 1e-15);
        assert_eq!(g.centre(2, 0), 0.0);
    }

    #[test]
    fn sweep_and_orientation_parsing() {
        assert_eq!(parse_sweep("0:10:3").unwrap(), vec![0.0, 5.0, 10.0]);
        assert_eq!(parse_sweep("2:9:1").unwrap(), vec![2.0]);
        assert!(parse_sweep("0:10").is_err());
        assert!(parse_sweep("0:x:3").is_err());
        assert!(parse_sweep("0:1:0").is_err());
        assert_eq!(
            parse_orientation(Some("0.1, 0, -0.2"), RobotKind::Spatial6).unwrap(),
            vec![0.1, 0.0, -0.2]
        );
        assert_eq!(parse_orientation(None, RobotKind::Planar3).unwrap(), vec![0.0]);
        assert!(parse_orientation(Some("0.1"), RobotKind::Spatial6).is_err());
        assert!(parse_orientation(Some("0.1"), RobotKind::Planar2).is_err());
    }
}

mod robot {
    use cdpr::robot::*;
    use robot_file::RobotFile;
    use std::path::PathBuf;

    #[test]
    fn every_shape_dispatches() {
        for &(n, m) in SHAPES {
            let kind = match n {
                6 => "spatial6",
                3 => "planar3",
                _ => "planar2",
            };
            let mut text = format!(
                "name = \"t\"\nkind = \"{kind}\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 1.0\ngravity = [0.0, 0.0, -9.81]\n"
            );
            for i in 0..m {
                let a = i as f64 * std::f64::consts::TAU / m as f64;
                text.push_str(&format!(
                    "[[cable]]\nanchor = [{}, {}, 1.0]\nattach = [0.0, 0.0, 0.0]\n",
                    a.cos(),
                    a.sin()
                ));
            }
            let file = RobotFile::parse(&text).unwrap();
            let loaded = LoadedRobot { path: PathBuf::from("t.toml"), file };
            let model = loaded.model().unwrap();
            assert_eq!((model.dof(), model.cables()), (n, m));
            // The geometry through the same dispatch: a pose below the
            // anchors' centre, every cable's force part a unit vector, the
            // lengths those of the anchors, gravity's wrench -m g.
            let mut pose = vec![0.0; n];
            if n == 6 {
                pose[2] = 0.5;
            }
            let (mut w, mut lengths, mut f) = (vec![0.0; n * m], vec![0.0; m], vec![0.0; n]);
            model.wrench_matrix(&pose, &mut w).unwrap();
            model.cable_lengths(&pose, &mut lengths).unwrap();
            model.required_wrench(&Query::pose(&pose), &mut f).unwrap();
            let force_rows = if n == 6 { 3 } else { 2 };
            for (i, length) in lengths.iter().enumerate() {
                let norm: f64 = (0..force_rows).map(|r| w[r * m + i] * w[r * m + i]).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < 1e-12, "{n}x{m} cable {i}: |u| = {norm}");
                let want = if n == 6 { 1.25f64.sqrt() } else { 1.0 };
                assert!((length - want).abs() < 1e-12, "{n}x{m} cable {i}: length {length}");
            }
            if n == 6 {
                assert!((f[2] - 9.81).abs() < 1e-12, "{f:?}");
            }
            assert!(model.wrench_matrix(&pose[1..], &mut w).is_err());
            assert!(model.winch().is_none());
        }
    }
}

mod table {
    use cdpr::table::*;
    use cdpr::CliError;
    use std::path::Path;
    use tension_core::RobotKind;

    fn parse(text: &str, kind: RobotKind, time: TimeColumn) -> Result<PoseTable, CliError> {
        let raw = parse_csv(Path::new("p.csv"), text)?;
        poses_from_raw(&raw, kind, time)
    }

    #[test]
    fn reads_columns_by_name_with_time_and_extras() {
        let t = parse(
            "time,x,y,fx,fy\r\n0.5, 1, 2, 3, 4\n\n1.0,5,6,7,8\n",
            RobotKind::Planar2,
            TimeColumn::Optional,
        )
        .unwrap();
        assert!(t.has_time && t.has_extra);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[0].time, Some(("0.5".into(), 0.5)));
        assert_eq!(t.rows[1].pose, vec![5.0, 6.0]);
        assert_eq!(t.rows[1].extra, Some(vec![7.0, 8.0]));
        assert_eq!(t.rows[1].line, 4);
        let t = parse("\u{feff}x,y\n  \n\"1\",2\r\n", RobotKind::Planar2, TimeColumn::Optional).unwrap();
        assert_eq!((t.rows[0].line, t.rows[0].pose.clone()), (3, vec![1.0, 2.0]));
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse("x,y\n1,2\n3,abc\n", RobotKind::Planar2, TimeColumn::Optional).unwrap_err();
        assert_eq!(e.message, "p.csv, line 3, column 2 (y): `abc` is not a number");
        // (table, time column, what the message contains)
        let cases = [
            ("x,z\n", TimeColumn::Optional, "p.csv, line 1, column 2: unknown column `z`"),
            ("x\n", TimeColumn::Optional, "p.csv, line 1: missing column `y`"),
            ("x,y,fx\n", TimeColumn::Optional, "missing column `fy`"),
            ("x,y\n1,2,3\n", TimeColumn::Optional, "p.csv, line 2: 3 fields, the header has 2"),
            ("x,y\n", TimeColumn::Required, "missing column `time`"),
            ("time,x,y\n1,0,0\n1,0,0\n", TimeColumn::Required, "p.csv, line 3, column 1 (time):"),
            ("time,x,y\n1,nan,0\n", TimeColumn::Required, "not a finite number"),
        ];
        for (text, time, wanted) in cases {
            let e = parse(text, RobotKind::Planar2, time).unwrap_err();
            assert!(e.message.contains(wanted), "{text:?}: {}", e.message);
        }
        assert!(parse("", RobotKind::Planar2, TimeColumn::Optional).is_err());
    }

    #[test]
    fn lines_of_a_long_table_with_blank_lines() {
        // Every line counted from the previous record's: blank lines, CRLF
        // and an error deep in the file still name the right line.
        let mut text = String::from("x,y\r\n");
        let mut want = vec![];
        let mut line = 2;
        for i in 0..3000 {
            if i % 7 == 0 {
                text.push_str("\n \r\n");
                line += 2;
            }
            text.push_str(&format!("{i},1\r\n"));
            want.push(line);
            line += 1;
        }
        let t = parse(&text, RobotKind::Planar2, TimeColumn::Optional).unwrap();
        assert_eq!(t.rows.iter().map(|r| r.line).collect::<Vec<_>>(), want);
        text.push_str("\n1,oops\n");
        let e = parse(&text, RobotKind::Planar2, TimeColumn::Optional).unwrap_err();
        assert!(e.message.starts_with(&format!("p.csv, line {}, column 2 (y)", line + 1)), "{}", e.message);
    }
}
