"""Known optimal costs, worked out by hand, shared by every test that checks a planner against them.

From the restaurant's :init (knife and bowl clean; the same on both layouts).
serve-water: pick 100, move 225, fill 1000, move 50, place 100 (5 actions).
make-coffee: pick 100, move 25, place 100, brew 50, pick 100, move 175, place 100.
clear: move 200, pick the plate 100. fruit-bowl: pick knife 100, cut 100, place
knife 100, pick bowl 100, move 200, place 100.
"""

START_COSTS = {
    "serve-water(servingtable)": 1475,
    "make-coffee(servingtable)": 650,
    "clear(servingtable)": 300,
    "fruit-bowl(servingtable)": 700,
}
SERVE_WATER_ACTIONS = 5
