"""The model as a networkx graph: elements, junctions and sensors as nodes, bonds as edges.

Power bonds keep their integer id as edge key; a sensor is joined to its junction by a signal
bond whose key is the sensor's name (it carries no power).

The three-tank system: 7 elements, 5 junctions and 2 sensors; 11 power bonds and 2 signal bonds.
The first tank's 0-junction takes the pump's flow in (bond 1, sign +1) and gives to the tank,
the first valve's 1-junction and the pressure sensor p1:

>>> from bondgraph.loader import load_model
>>> m = load_model("models/three_tank.yaml")
>>> g = to_networkx(m)
>>> g.number_of_nodes(), sum(not s for *_, s in g.edges(data="signal")), sum(s for *_, s in g.edges(data="signal"))
(14, 11, 2)
>>> ports(g, "J1")
[(1, 'pump', 1), (2, 'tank1', -1), (3, 'V1', -1), ('p1', 'p1', -1)]
"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:                       # networkx is imported where a graph is built (bgfdi's warm start needs none)
    import networkx as nx

from .model import Model

BondKey = int | str


def to_networkx(model: Model) -> nx.MultiDiGraph:
    """A MultiDiGraph with edges in power direction; node attribute ``kind`` is the element,
    junction (0, 1, 0c, 1c) or sensor (De, Df) type; edge attribute ``signal`` marks sensor bonds."""
    import networkx as nx
    g = nx.MultiDiGraph(name=model.name)
    for e in model.elements.values():
        g.add_node(e.name, kind=e.kind, role="element")
    for j in model.junctions.values():
        g.add_node(j.name, kind=j.kind, role="junction", mode=j.mode)
    for s in model.sensors.values():
        g.add_node(s.name, kind=s.kind, role="sensor")
    for b in model.bonds:
        g.add_edge(b.source, b.target, key=b.id, signal=False)
    for s in model.sensors.values():
        g.add_edge(s.junction, s.name, key=s.name, signal=True)
    return g


def port_table(g: nx.MultiDiGraph) -> dict[str, list[tuple[BondKey, str, int]]]:
    """:func:`ports` of every node, in one pass over the edges."""
    table: dict[str, list[tuple[BondKey, str, int]]] = {n: [] for n in g.nodes}
    for u, v, k in g.edges(keys=True):
        table[u].append((k, v, -1))
        table[v].append((k, u, +1))
    for ps in table.values():
        ps.sort(key=_port_order)
    return table


def _port_order(p: tuple[BondKey, str, int]) -> tuple:
    """Power bonds by id, then signal bonds by name; out-going before in-coming on a self-loop."""
    return (isinstance(p[0], str), str(p[0]) if isinstance(p[0], str) else p[0])


def ports(g: nx.MultiDiGraph, node: str) -> list[tuple[BondKey, str, int]]:
    """(bond key, neighbour, sign) for each bond of ``node``; sign +1 if power flows into it."""
    out = [(k, v, -1) for _, v, k in g.out_edges(node, keys=True)]
    out += [(k, u, +1) for u, _, k in g.in_edges(node, keys=True)]
    return sorted(out, key=_port_order)

