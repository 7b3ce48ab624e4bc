; The minimal example of the thesis (§5.1, Figure 5.1): a 5x5 grid with three
; receptacles A (bottom-left), B (bottom-right) and C (top-centre). Each step
; costs 1; the RL reward uses the same units (cost_scale = 1 in domain.toml).
(define (domain minimal)
  (:requirements :typing :negative-preconditions :existential-preconditions :action-costs)
  (:types cell thing - object
          fruit - thing)
  (:predicates
    (robot-at ?c - cell)
    (hand-free)
    (holding ?t - thing)
    (at ?t - thing ?c - cell)
    (adjacent ?a ?b - cell)
    (receptacle ?c - cell))
  (:functions (total-cost) - number)

  (:action move
    :parameters (?from ?to - cell)
    :precondition (and (robot-at ?from) (adjacent ?from ?to))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) 1)))

  (:action pick
    :parameters (?t - thing ?c - cell)
    :precondition (and (hand-free) (robot-at ?c) (at ?t ?c))
    :effect (and (not (hand-free)) (holding ?t) (not (at ?t ?c)) (increase (total-cost) 1)))

  (:action place
    :parameters (?t - thing ?c - cell)
    :precondition (and (holding ?t) (robot-at ?c) (receptacle ?c))
    :effect (and (hand-free) (not (holding ?t)) (at ?t ?c) (increase (total-cost) 1))))
