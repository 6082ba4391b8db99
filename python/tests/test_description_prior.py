"""drops.DescriptionPrior (a URDF or MJCF file as the simulator prior, issue 64): the example
(examples/python/description_prior.py) learns from the DFKI double pendulum's URDF and GP-MI finds
the real robot's phi; a run uses the C++ prior, never a Python evaluate; bad input is refused
naming the file and the item before anything runs; missing visual meshes are only a warning."""

import sys
import warnings

import numpy as np
import pytest

import drops
from conftest import SOURCE_DIR

sys.path.insert(0, str(SOURCE_DIR / "examples" / "python"))
with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the DFKI file's visual meshes are not shipped
    import description_prior as example  # noqa: E402

URDF = str(SOURCE_DIR / "tests" / "data" / "double-pendulum-dfki" / "double_pendulum.urdf")
QUIET = dict(quiet=True, progress=lambda line: None)


def prior(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return drops.DescriptionPrior(*args, **kwargs)


def test_the_example_identifies_the_real_phi_and_its_return_improves(tmp_path):
    settings = {"model.type": "gp_mi", "episodes": 2, "optimizer.max_evaluations": 150,
                "optimizer.prior_optimizations": 1}
    out = drops.run(overrides=settings, seed=1, output=tmp_path, name="urdf", **QUIET,
                    task=example.SwingUp(), system=example.RealPendulum(), prior=example.prior)
    assert out.status == "complete"
    run = drops.read_run(out.directory)
    assert run.phi_names == ["Link2.mass", "Joint1.damping"]
    np.testing.assert_allclose(run.episodes["phi"][0], [0.6306, 0.08089])  # the file's
    # After one real episode GP-MI finds the real robot's values (the prior is then exact).
    np.testing.assert_allclose(run.episodes["phi"][-1], [0.9, 0.25], rtol=0.02)
    returns = run.episodes["real_return"]
    assert returns[1] > returns[0] + 2, returns


def test_a_run_uses_the_cpp_prior_and_never_a_python_evaluate(tmp_path):
    class Watched(drops.DescriptionPrior):
        def evaluate(self, x, u, phi=None, dt=0.01):
            raise AssertionError("the run called the Python evaluate")

    p = prior(URDF, parameters=example.parameters(), label="watched")
    p.__class__ = Watched
    settings = {"model.type": "gp_mi", "episodes": 2, "optimizer.max_evaluations": 40,
                "optimizer.prior_optimizations": 1}
    out = drops.run(overrides=settings, seed=3, output=tmp_path, name="w", **QUIET,
                    task=example.SwingUp(), system=example.RealPendulum(), prior=p)
    assert out.status == "complete"


def test_evaluate_keeps_a_hanging_pendulum_still_and_two_half_periods_make_one_period():
    p = prior(URDF, parameters=["Link2.mass", "gravity", "Joint1.friction", "Joint2.friction"])
    assert p.joint_names == ["Joint1", "Joint2"] and p.actuated_joint_names == ["Joint1", "Joint2"]
    assert p.body_names() == ["base_link", "Link1", "Link2", "Weight"]
    assert "Joint2.armature" in p.available_parameters()
    np.testing.assert_allclose(p.default_phi(), [0.6306, 9.81, 0.09335, 0.1865])
    assert [q.unit for q in p.parameters] == ["kg", "m/s^2", "N m", "N m"]
    assert not any(q.tunable for q in p.parameters)  # plain names are fixed
    # Hanging at rest without torque it stays (up to 3e-7: the file turns Link2 by -3.1416, not
    # pi, so its centre of mass hangs 7e-6 rad off the vertical).
    assert np.abs(p.evaluate(np.zeros((3, 4)), np.zeros((3, 2)))).max() < 1e-6
    rng = np.random.default_rng(4)
    x = np.column_stack([rng.uniform(-3, 3, (5, 2)), rng.uniform(-2, 2, (5, 2))])
    u = rng.uniform(-1, 1, (5, 2))
    # Without the stiff smoothed Coulomb friction (tanh(qd / 0.01 rad/s)), RK4 of h = 2 ms
    # agrees with h = 1 ms.
    phi = [0.6306, 9.81, 0.0, 0.0]
    one = p.evaluate(x, u, phi, dt=0.02)
    half = p.evaluate(x, u, phi, dt=0.01)
    two = half + p.evaluate(x + half, u, phi, dt=0.01)
    np.testing.assert_allclose(one, two, atol=1e-7)
    assert np.abs(one).max() > 1e-3
    with pytest.raises(drops.InvalidArgument, match=r"expected x \(B, 4\), u \(B, 2\)"):
        p.evaluate(np.zeros((3, 3)), np.zeros((3, 2)))


def test_bad_input_is_refused_naming_the_file_and_the_item(tmp_path):
    broken = tmp_path / "broken.urdf"
    broken.write_text('<robot name="r"><link name="a"></robot>')
    with pytest.raises(drops.InvalidArgument, match="broken.urdf.*does not load"):
        drops.DescriptionPrior(broken)
    with pytest.raises(drops.InvalidArgument,
                       match=r"'Link3.mass'.*base_link, Link1, Link2, Weight"):
        prior(URDF, parameters=["Link3.mass"])
    with pytest.raises(drops.InvalidArgument, match=r"no joint named 'Elbow'.*Joint1, Joint2"):
        prior(URDF, joints=["Joint1", "Elbow"])
    with pytest.raises(ValueError, match=r"double_pendulum.urdf.*Link2.mass: bounds \[-0.1, 1\]"
                                         r": non-physical: a mass: >= 0 kg"):
        prior(URDF, parameters=[drops.Parameter("Link2.mass", lower=-0.1, upper=1.0)])
    with pytest.raises(ValueError, match=r"Link1.inertia: bounds \[0, 2\]: non-physical"):
        prior(URDF, parameters=[drops.Parameter("Link1.inertia", lower=0.0, upper=2.0)])
    with pytest.raises(ValueError, match="Joint1.damping: bounds.*expected finite bounds"):
        prior(URDF, parameters=[drops.Parameter("Joint1.damping")])  # tunable, no bounds
    with pytest.raises(ValueError, match=r"Link2.mass = 2.0: the value must lie in its bounds"):
        prior(URDF, parameters=[drops.Parameter("Link2.mass", 2.0, 0.3, 1.5)])
    floating = tmp_path / "floating.xml"
    floating.write_text('<mujoco><worldbody><body name="torso"><freejoint name="base"/>'
                        '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>'
                        '</worldbody></mujoco>')
    with pytest.raises(drops.InvalidArgument, match=r"floating.xml.*'base' is free"):
        drops.DescriptionPrior(floating)
    with pytest.raises(TypeError, match="parameters"):
        drops.DescriptionPrior(URDF, parameters="Link2.mass")
    p = prior(URDF, parameters=["Link2.mass"])
    with pytest.raises(ValueError, match=r"Link2.mass = -1: expected a mass"):
        p.check_phi([-1.0])
    with pytest.raises(ValueError, match=r"Link2.mass: bounds \[-1, 1\]"):
        p.check_bounds("Link2.mass", -1, 1)
    assert p.parameter_domain(0)["unit"] == "kg"


def test_missing_visual_meshes_are_a_warning_and_the_prior_loads(tmp_path):
    with pytest.warns(UserWarning, match=r"the mesh files ./meshes/base_link.obj.*do not exist"):
        p = drops.DescriptionPrior(URDF)
    assert len(p.warnings) == 1
    arm = tmp_path / "arm.urdf"
    arm.write_text("""<robot name="arm"><link name="base"/>
      <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
        <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
        <visual><geometry><mesh filename="nowhere/arm.stl"/></geometry></visual></link>
      <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/>
        <axis xyz="1 0 0"/></joint></robot>""")
    with pytest.warns(UserWarning, match="nowhere/arm.stl"):
        p = drops.DescriptionPrior(arm, parameters=["arm.mass"])
    assert p.joint_names == ["hinge"]


def test_a_task_of_other_dimensions_is_refused_at_run_naming_the_joints(tmp_path):
    class OneJoint(example.SwingUp):
        state_names = ["q1", "dq1"]
        action_names = ["tau1"]
        observation_dim, observation_scale = 2, None

        def initial_state(self):
            return np.zeros(2)

    with pytest.raises(ValueError, match=r"E = 2 states and A = 1 actions, the prior E = 4 \(the "
                                         r"positions then the velocities of Joint1, Joint2"):
        drops.run(output=tmp_path, **QUIET, task=OneJoint(), system=example.RealPendulum(),
                  prior=example.prior)
    assert not any(tmp_path.iterdir())  # refused before anything ran


def test_a_plain_prior_still_needs_a_value():
    class P(drops.Prior):
        parameters = [drops.Parameter("m", lower=0.1, upper=2.0)]

    with pytest.raises(TypeError, match=r"m.value: None \(only a drops.DescriptionPrior"):
        drops.run(task=example.SwingUp(), system=example.RealPendulum(), prior=P())


def test_a_builtin_task_takes_its_prior_from_a_file_given_by_the_configuration(tmp_path):
    # configs/pendubot-gp_mi-file.yaml: the pendubot with tasks/pendubot/data/pendubot.xml as
    # prior.model, resolved by the module's description-prior factory as by the command line.
    config = SOURCE_DIR / "configs" / "pendubot-gp_mi-file.yaml"
    resolved = drops.config(str(config))
    assert "pendubot.xml" in resolved and "Link2.com.z" in resolved
    out = drops.run(str(config), {"episodes": 1, "optimizer.max_evaluations": 50}, seed=1,
                    output=tmp_path, name="file", **QUIET)
    assert out.status == "complete"
    run = drops.read_run(out.directory)
    assert "Link2.com.z" in run.phi_names
    with pytest.raises(drops.Error, match="Link9"):
        drops.config(str(config), {"prior.parameters": "[{name: Link9.mass, bounds: [0.1, 1]}]"})
