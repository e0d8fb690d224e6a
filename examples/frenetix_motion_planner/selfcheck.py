"""`make check`: start serve.py as simgap would, and plan two cycles on a 60 m straight two-lane
road (a CommonRoad XML made here), the second beside a parked car; no simgap needed.
Prints the first plan's start and end and exits non-zero on any failure."""

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import zmq
from simgap_planner import simgap_planner_pb2 as pb
from simgap_planner.messages import PROTOCOL_VERSION, Trajectory, trajectory_columns, trajectory_message

HERE = Path(__file__).resolve().parent


def road_xml() -> str:
    """A straight road along +x: lane 1 (y in [-3, 0]) with the agent, lane 2 beside it (y in [0, 3]),
    driving the other way; the goal 10 m before the end of lane 1."""
    def bound(y, xs):
        return "".join(f"<point><x>{x}</x><y>{y}</y></point>" for x in xs)
    xs, back = [0.0, 30.0, 60.0], [60.0, 30.0, 0.0]
    lanelets = (f'<lanelet id="1"><leftBound>{bound(0.0, xs)}<lineMarking>dashed</lineMarking></leftBound>'
                f'<rightBound>{bound(-3.0, xs)}<lineMarking>solid</lineMarking></rightBound>'
                f'<adjacentLeft ref="2" drivingDir="opposite"/><laneletType>urban</laneletType></lanelet>'
                f'<lanelet id="2"><leftBound>{bound(0.0, back)}<lineMarking>dashed</lineMarking></leftBound>'
                f'<rightBound>{bound(3.0, back)}<lineMarking>solid</lineMarking></rightBound>'
                f'<adjacentLeft ref="1" drivingDir="opposite"/><laneletType>urban</laneletType></lanelet>')
    problem = ('<planningProblem id="10"><initialState><time><exact>0</exact></time>'
               '<position><point><x>5.0</x><y>-1.5</y></point></position>'
               '<orientation><exact>0.0</exact></orientation><velocity><exact>5.0</exact></velocity>'
               '<acceleration><exact>0.0</exact></acceleration><yawRate><exact>0.0</exact></yawRate>'
               '<slipAngle><exact>0.0</exact></slipAngle></initialState>'
               '<goalState><time><intervalStart>0</intervalStart><intervalEnd>200</intervalEnd></time>'
               '<position><rectangle><length>6.0</length><width>3.0</width><orientation>0.0</orientation>'
               '<center><x>50.0</x><y>-1.5</y></center></rectangle></position></goalState></planningProblem>')
    return ("<?xml version='1.0' encoding='UTF-8'?>"
            '<commonRoad timeStepSize="0.1" commonRoadVersion="2020a" author="selfcheck" affiliation="" '
            'source="selfcheck" benchmarkID="ZAM_Selfcheck-1_1_T-1" date="2026-01-01">'
            "<location><geoNameId>-999</geoNameId><gpsLatitude>999</gpsLatitude>"
            "<gpsLongitude>999</gpsLongitude></location><scenarioTags><Urban/></scenarioTags>"
            f"{lanelets}{problem}</commonRoad>")


def main() -> int:
    folder = Path(tempfile.mkdtemp(prefix="frenetix-check-"))
    endpoint = f"ipc://{folder}/planner.sock"
    server = subprocess.Popen([sys.executable, str(HERE / "serve.py")],
                              env={**os.environ, "SIMGAP_PLANNER_ENDPOINT": endpoint})
    socket = zmq.Context.instance().socket(zmq.REQ)
    socket.setsockopt(zmq.LINGER, 0)
    socket.connect(endpoint)

    def call(request: pb.Request) -> pb.Reply:
        socket.send(request.SerializeToString())
        if not socket.poll(120_000):
            raise SystemExit("selfcheck: no answer within 120 s")
        reply = pb.Reply.FromString(socket.recv())
        if reply.HasField("error"):
            raise SystemExit(f"selfcheck: {reply.error.type}: {reply.error.message}\n{reply.error.traceback}")
        return reply

    try:
        request = pb.Request(id=1)
        init = request.initialize
        init.protocol_version, init.agent_id, init.dt, init.commonroad_xml = PROTOCOL_VERSION, 10, 0.1, road_xml()
        v = init.vehicle        # simgap's sedan: CommonRoad's vehicle 2 (BMW 320i)
        v.name, v.length, v.width, v.wheelbase, v.rear_axle_to_center = "sedan", 4.508, 1.61, 2.57877, 1.4227
        v.max_steer, v.max_steer_rate, v.max_accel, v.max_speed, v.v_switch = 1.066, 0.4, 11.5, 50.8, 7.319
        v.commonroad_vehicle_type = 2
        session = call(request).ready.session
        for cycle, parked in enumerate((False, True)):
            request = pb.Request(id=2 + cycle)
            plan = request.plan
            plan.session, plan.t = session, 0.1 * cycle
            plan.observed.t, plan.observed.x, plan.observed.y, plan.observed.v = 0.1 * cycle, 5.0 + 0.5 * cycle, -1.5, 5.0
            if parked:
                other = plan.traffic.add()
                other.id, other.length, other.width = 99, 4.5, 1.8
                n = 31
                trajectory_message(Trajectory(0.1, t=plan.t + 0.1 * np.arange(n), x=np.full(n, 25.0),
                                              y=np.full(n, -1.5)), other.prediction)
            reply = call(request).plan
            if reply.HasField("no_plan"):
                raise SystemExit(f"selfcheck: no plan in cycle {cycle}: {reply.no_plan}")
            c = trajectory_columns(reply.trajectory)
            if abs(c["t"][0] - plan.t) > 0.05 or not np.all(np.isfinite(np.column_stack(list(c.values())))):
                raise SystemExit(f"selfcheck: a plan that starts at {c['t'][0]} or is not finite")
            print(f"cycle {cycle}{' (a car parked ahead at x=25)' if parked else ''}: {len(c['t'])} states, "
                  f"({c['x'][0]:.2f}, {c['y'][0]:.2f}) at t={c['t'][0]:.1f} s to ({c['x'][-1]:.2f}, "
                  f"{c['y'][-1]:.2f}) at {c['v'][-1]:.2f} m/s at t={c['t'][-1]:.1f} s")
        call(pb.Request(id=9, close=pb.Close(session=session)))
        server.wait(timeout=30)
        print(f"selfcheck: ok (the server ended with {server.returncode} after the session closed)")
        return server.returncode
    finally:
        if server.poll() is None:
            server.kill()


if __name__ == "__main__":
    sys.exit(main())
