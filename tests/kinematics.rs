//! The gear set's kinematics the front ends read (`model::kinematics`):
//! the balanced torques do no net work at the rigid-body speeds (a lossless
//! set passes the input power to the output), and the mesh cycles per input
//! revolution are the sun's teeth passing the planets, Z_s |ω_s − ω_c|.

use planetwear::model::gear::Member;
use planetwear::model::kinematics::Kinematics;
use planetwear::scene::Scene;

#[test]
fn balanced_torques_pass_the_input_power_and_the_mesh_cycles_follow_willis() {
    let members = [Member::Sun, Member::Ring, Member::Carrier];
    let mut checked = 0;
    for held in members {
        for input in members.into_iter().filter(|m| *m != held) {
            let mut scene = Scene::example_2004();
            (scene.operation.held, scene.operation.input) = (held, input);
            let Ok(set) = scene.validate() else { continue };
            let k = Kinematics::of(&set);
            let index = |m: Member| members.iter().position(|x| *x == m).unwrap();
            let power: f64 = (0..3).map(|i| k.balanced_torques_per_input_torque[i] * k.rigid_speeds[i]).sum();
            assert!(power.abs() < 1e-12, "{held:?} held, {input:?} in: net power {power}");
            // The input member takes the input torque (on the carrier as the tooth forces'
            // sign gives it: −T for a positive input torque).
            assert!((k.balanced_torques_per_input_torque[index(input)].abs() - 1.0).abs() < 1e-12);
            assert_eq!(k.balanced_torques_per_input_torque[index(held)], 0.0);
            assert_eq!(k.rigid_speeds[index(input)], 1.0);
            assert_eq!(k.rigid_speeds[index(held)], 0.0);
            let willis = f64::from(k.teeth[0]) * (k.rigid_speeds[0] - k.rigid_speeds[2]).abs();
            assert!(
                (k.mesh_cycles_per_input_revolution - willis).abs() < 1e-12 * willis,
                "{held:?} held, {input:?} in: {} mesh cycles per revolution against Willis {willis}",
                k.mesh_cycles_per_input_revolution
            );
            checked += 1;
        }
    }
    assert!(checked >= 2, "only {checked} held/input pairs make a valid example set");
}

#[test]
fn the_example_reads_as_the_study_gives_it() {
    let k = Kinematics::of(&Scene::example_2004().validate().unwrap());
    assert_eq!(k.teeth, [34, 18, 70]);
    assert_eq!(k.planets, 4);
    assert_eq!(k.mesh_cycles_per_input_revolution, 34.0);
    // Carrier held, sun in: the ring turns back at Z_s/Z_r and carries Z_r/Z_s of the torque.
    assert!((k.rigid_speeds[1] + 34.0 / 70.0).abs() < 1e-15);
    assert!((k.balanced_torques_per_input_torque[1] - 70.0 / 34.0).abs() < 1e-12);
}
