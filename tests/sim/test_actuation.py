"""Between a physics world's controller and its car: every field of the controller's command is
delivered by one actuator channel, and each channel's dead time and lag are set by the knobs it
declares, those and no others; restoring the actuators assumption leaves a perfect machine."""

from __future__ import annotations

import pytest

from simgap.control.protocol import COMMAND_FIELDS
from simgap.experiment.knobs import KNOBS
from simgap.sim.assumptions import Assumption
from simgap.sim.settings import TrackingSettings
from simgap.vehicles import load_vehicle, vehicle_names
from simgap.vehicles.channels import CHANNELS, Brake, Drive, Steering, knob_names, timing_knobs


def test_each_command_field_has_the_one_channel_that_delivers_it():
    assert sorted(c.command for c in CHANNELS.values()) == sorted(COMMAND_FIELDS)


def test_every_channels_knobs_are_tracking_settings_and_reality_knobs():
    assert knob_names()[:4] == ["steer_delay", "steer_lag", "pedal_delay", "pedal_lag"]     # users' specs name them
    for name in knob_names():
        assert name in TrackingSettings.model_fields and KNOBS[name].model is TrackingSettings
    for pair in timing_knobs():
        assert KNOBS[pair.delay].meaning == f"{pair.subject} dead time"


@pytest.mark.parametrize("knob, value, sets, leaves", [
    ("steer_delay", 0.3, {Steering}, {Drive, Brake}),
    ("steer_lag", 0.05, {Steering}, {Drive, Brake}),
    ("pedal_delay", 0.3, {Drive, Brake}, {Steering}),
    ("pedal_lag", 0.4, {Drive, Brake}, {Steering}),
])
def test_a_knob_sets_exactly_its_channels(knob, value, sets, leaves):
    sedan = load_vehicle("sedan")
    own, tuned = sedan.actuators, TrackingSettings(**{knob: value}).actuators(sedan)
    declaring = {c for c in CHANNELS.values() if knob in c.knobs.names}
    assert sets <= declaring and not leaves & declaring
    for channel in CHANNELS.values():
        if channel in declaring:
            assert (tuned[channel].dead_time if knob.endswith("delay") else tuned[channel].time_constant) == value
            assert tuned[channel] != own[channel]
        else:
            assert tuned[channel] == own[channel]


@pytest.mark.parametrize("name", vehicle_names())
def test_restoring_the_actuators_leaves_a_perfect_machine(name):
    vehicle = load_vehicle(name)
    assert not TrackingSettings().actuators(vehicle).ideal
    assert TrackingSettings(**TrackingSettings.ASSUMPTIONS[Assumption.ACTUATORS]).actuators(vehicle).ideal
    assert TrackingSettings(realism="ideal").actuators(vehicle).ideal
    # under realism ideal a knob still sets its channel over the perfect one
    late = TrackingSettings(realism="ideal", steer_delay=0.2).actuators(vehicle)
    assert late[Steering].dead_time == 0.2 and late[Drive].dead_time == 0.0
