//! A Sylvan forest in a Bevy app, with a fly camera, Bevy's sun and a few Bevy meshes standing
//! among the trees.
//!
//! ```text
//! cd crates/sylvan-bevy
//! cargo run --release --ignore-rust-version --example bevy_forest -- [SCENE.toml] [--technique NAME] [--screenshot PNG]
//! ```
//!
//! Controls: W/A/S/D move, Q/E down/up, Shift faster, drag with the left mouse button to look
//! around, Esc quits. `--screenshot PNG` saves the 10th frame and exits (for the README).
//! With no scene it draws Sylvan's built-in grove (`Scene::builtin_grove`: 6,381 trees on 1.28 km of hills).

use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use sylvan_bevy::{Forest, ForestCamera, ForestStats, SylvanPlugin};
use sylvan_render::Layers;

struct Args {
    scene: Option<String>,
    technique: String,
    screenshot: Option<String>,
}

fn args() -> Args {
    let mut a = Args {
        scene: None,
        technique: "auto".into(),
        screenshot: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--technique" => a.technique = it.next().unwrap_or(a.technique),
            "--screenshot" => a.screenshot = it.next(),
            s => a.scene = Some(s.to_string()),
        }
    }
    a
}

#[derive(Resource)]
struct Shot(Option<String>);

fn main() {
    let args = args();
    let forest = match &args.scene {
        Some(path) => Forest::load(path),
        None => Forest::from_scene(sylvan_scene::Scene::builtin_grove()),
    };
    let forest = match forest {
        Ok(f) => f.with_technique(&args.technique).with_layers(Layers::ALL),
        Err(e) => {
            eprintln!("bevy_forest: {e}");
            std::process::exit(1);
        }
    };
    App::new()
        .add_plugins((
            DefaultPlugins.set(WindowPlugin {
                primary_window: Some(Window {
                    title: "Sylvan in Bevy".into(),
                    resolution: (1280u32, 720u32).into(),
                    ..default()
                }),
                ..default()
            }),
            SylvanPlugin,
        ))
        .insert_resource(Shot(args.screenshot))
        .insert_resource(ForestSpawn(Some(forest)))
        .add_systems(Startup, setup)
        .add_systems(Update, (fly, report, screenshot))
        .run();
}

#[derive(Resource)]
struct ForestSpawn(Option<Forest>);

/// Fly-camera state: yaw and pitch in radians.
#[derive(Component)]
struct Fly {
    yaw: f32,
    pitch: f32,
}

fn setup(
    mut commands: Commands,
    mut spawn: ResMut<ForestSpawn>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let Some(forest) = spawn.0.take() else {
        return;
    };
    let cam = forest.scene().camera;
    let eye = Vec3::from_array(cam.position.to_array());
    let dir = (Vec3::from_array(cam.look_at.to_array()) - eye).normalize_or(Vec3::NEG_Z);
    // A few Bevy meshes on the terrain where the view's centre meets it.
    let mut ahead = eye + dir * 60.0;
    for t in 1..4000 {
        let p = eye + dir * t as f32 * 0.5;
        if p.y < forest.height_at(p.x, p.z) {
            ahead = p;
            break;
        }
    }
    let size = 2.0 + eye.distance(ahead) * 0.04;
    for (i, color) in [
        Color::srgb(0.8, 0.1, 0.1),
        Color::srgb(0.9, 0.8, 0.2),
        Color::srgb(0.2, 0.3, 0.9),
    ]
    .into_iter()
    .enumerate()
    {
        let side =
            Vec3::new(-dir.z, 0.0, dir.x).normalize_or(Vec3::X) * (i as f32 - 1.0) * size * 3.0;
        let p = ahead + side;
        let y = forest.height_at(p.x, p.z);
        commands.spawn((
            Mesh3d(meshes.add(Cuboid::new(size, size, size))),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: color,
                ..default()
            })),
            Transform::from_xyz(p.x, y + size * 0.5, p.z),
        ));
    }
    let sun = forest.scene().sun.direction();
    commands.spawn((
        DirectionalLight {
            illuminance: light_consts::lux::AMBIENT_DAYLIGHT,
            ..default()
        },
        Transform::default().looking_to(-Vec3::from_array(sun.to_array()), Vec3::Y),
    ));
    commands.spawn(forest);
    commands.spawn((
        Camera3d::default(),
        bevy::camera::Hdr,
        Projection::Perspective(PerspectiveProjection {
            fov: cam.fov_deg.to_radians(),
            ..default()
        }),
        Transform::from_translation(eye).looking_to(dir, Vec3::Y),
        Fly {
            yaw: dir.x.atan2(-dir.z),
            pitch: dir.y.asin(),
        },
        ForestCamera,
    ));
}

fn fly(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    mut exit: MessageWriter<AppExit>,
    mut camera: Query<(&mut Transform, &mut Fly)>,
) {
    if keys.just_pressed(KeyCode::Escape) {
        exit.write(AppExit::Success);
    }
    let Ok((mut t, mut fly)) = camera.single_mut() else {
        return;
    };
    if buttons.pressed(MouseButton::Left) {
        fly.yaw += motion.delta.x * 0.003;
        fly.pitch = (fly.pitch - motion.delta.y * 0.003).clamp(-1.5, 1.5);
    }
    t.rotation = Quat::from_euler(EulerRot::YXZ, -fly.yaw, fly.pitch, 0.0);
    let speed = if keys.pressed(KeyCode::ShiftLeft) {
        120.0
    } else {
        20.0
    };
    let mut v = Vec3::ZERO;
    for (key, d) in [
        (KeyCode::KeyW, *t.forward()),
        (KeyCode::KeyS, *t.back()),
        (KeyCode::KeyA, *t.left()),
        (KeyCode::KeyD, *t.right()),
        (KeyCode::KeyE, Vec3::Y),
        (KeyCode::KeyQ, Vec3::NEG_Y),
    ] {
        if keys.pressed(key) {
            v += d;
        }
    }
    t.translation += v.normalize_or_zero() * speed * time.delta_secs();
}

fn report(stats: Res<ForestStats>, mut frames: Local<u32>) {
    *frames += 1;
    if (*frames).is_multiple_of(120) {
        let f = stats.last();
        match f.error {
            Some(e) => warn!("sylvan: {e}"),
            None => info!(
                "sylvan: {} · plugin CPU {:.2} ms/frame · {} draw calls",
                f.technique, f.cpu_ms, f.draw_calls
            ),
        }
    }
}

fn screenshot(
    mut commands: Commands,
    shot: Res<Shot>,
    mut frames: Local<u32>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(path) = &shot.0 else {
        return;
    };
    *frames += 1;
    if *frames == 10 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(path.clone()));
    }
    if *frames == 14 {
        exit.write(AppExit::Success);
    }
}
