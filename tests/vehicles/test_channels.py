"""The actuator channels are data: each is defined once, every catalogue vehicle gives each its
numbers, and a channel defined elsewhere (a retarder, here in a test) is read from a vehicle's
``actuators`` and gets its response with no other change to simgap."""

from __future__ import annotations

from importlib import resources
from types import SimpleNamespace

import pytest
import yaml

from simgap.errors import InputError, validated
from simgap.sim.settings import TrackingSettings
from simgap.trajectory import State
from simgap.vehicles import load_vehicle, vehicle_names
from simgap.vehicles.actuators import IDEAL_CHANNEL, ActuatorChannel, ActuatorResponses, Actuators
from simgap.vehicles.catalogue import Vehicle, load_vehicle_file
from simgap.vehicles.channels import CHANNELS, PEDAL_KNOBS, Brake, Channel, Drive, Steering, channel_table

PERIOD = 0.01


@pytest.mark.parametrize("name", vehicle_names())
def test_every_vehicle_file_gives_every_channel_its_numbers_and_their_source(name):
    raw = yaml.safe_load((resources.files("simgap.vehicles") / "data" / f"{name}.yaml").read_text())
    assert list(raw["actuators"]) == list(CHANNELS)
    assert all(section["source"] for section in raw["actuators"].values())


@pytest.fixture
def retarder():
    """A channel defined as a new one would be: one class (removed again after the test)."""

    class Retarder(Channel):
        section = "retarder"
        command = "retard"
        knobs = PEDAL_KNOBS
        description = "driveline brake torque request: the retarder lever in [0, 1]"

    yield Retarder
    del CHANNELS[Retarder.section]


def test_a_new_channel_is_read_from_the_vehicle_file_and_responds(retarder):
    sedan = load_vehicle("sedan").model_dump(mode="json")
    sedan["actuators"]["retarder"] = {"dead_time": 0.03, "source": "a test"}
    vehicle = validated(Vehicle, sedan)
    assert vehicle.actuators[retarder] == ActuatorChannel(dead_time=0.03, source="a test")
    assert vehicle.actuators.summary().endswith(", retarder 0.03 s dead time")
    responses = ActuatorResponses(vehicle.actuators, PERIOD, State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=5.0, steer=0.1))
    asked = SimpleNamespace(**{c.command: 0.0 for c in CHANNELS.values()} | {"retard": 1.0})
    assert [responses.respond(asked)[-1] for _ in range(5)] == [0.0, 0.0, 0.0, 1.0, 1.0]   # three periods late
    # a vehicle file without the section: the channel acts at once
    assert Vehicle.model_validate(load_vehicle("suv").model_dump()).actuators[retarder] == IDEAL_CHANNEL
    assert "`retarder` | `retard`" in channel_table()
    # the knobs it declares set it as they set the pedals
    assert TrackingSettings(pedal_delay=0.2).actuators(vehicle)[retarder].dead_time == 0.2


def test_a_channel_is_defined_once():
    with pytest.raises(ValueError, match="Steering"):
        class SecondSteering(Channel):
            section = "steering"
            command = "rear_steer"
            knobs = PEDAL_KNOBS
            description = "a second steering"
    assert CHANNELS["steering"] is Steering


def test_a_section_that_is_no_channels_is_refused_naming_the_channels(tmp_path):
    text = (resources.files("simgap.vehicles") / "data" / "sedan.yaml").read_text()
    path = tmp_path / "misspelt.yaml"
    path.write_text(text.replace("  drive:\n    dead_time", "  drve:\n    dead_time", 1))
    with pytest.raises(InputError) as err:
        load_vehicle_file(path)
    assert err.value.field == "actuators" and err.value.allowed == ", ".join(CHANNELS)
    assert "'drve' is no actuator channel" in str(err.value)


def test_the_ideal_car_has_every_channel_acting_at_once():
    assert Actuators().ideal and list(Actuators().root) == list(CHANNELS)
    assert not Actuators({"brake": {"dead_time": 0.1}}).ideal
    assert Actuators({"brake": {"dead_time": 0.1}})[Drive] == IDEAL_CHANNEL


def test_a_cars_actuators_say_what_they_are_in_a_line():
    # the run record's note of the car's actuators, as before the channels were a table
    assert load_vehicle("sedan").actuators.summary().startswith(
        "steering 0.12 s dead time + lag 0.1 s, drive 0.15 s dead time + lag 0.1 s, brake 0.15 s dead time + lag 0.1 s")


def test_each_channel_responds_as_its_own_response_does():
    """`ActuatorResponses` steps each channel's response with its request, the steering from the
    car's angle and the pedals from released, and answers in the order asked."""
    actuators = load_vehicle("sedan").actuators
    start = State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=5.0, steer=0.2)
    order = list(reversed(CHANNELS.values()))
    responses = ActuatorResponses(actuators, PERIOD, start, [c.command for c in order])
    assert (responses[Steering].output, responses[Drive].output, responses[Brake].output) == (0.2, 0.0, 0.0)
    by_hand = {c: actuators[c].response(PERIOD, c.start(start)) for c in order}
    for k in range(40):
        asked = SimpleNamespace(**{c.command: 0.1 * n * (k > 5 * n) for n, c in enumerate(order, 1)})
        assert responses.respond(asked) == tuple(by_hand[c].step(getattr(asked, c.command)) for c in order)
    with pytest.raises(ValueError, match="deliver steer, throttle, brake"):
        ActuatorResponses(actuators, PERIOD, start, ("steer", "throttle"))
