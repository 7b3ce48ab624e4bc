; Shared names (front-end test): `charge` is a type and an action, `refill` a constant and an
; action. PDDL keeps them apart; unified-planning keeps one namespace, so the bridge renames.
(define (domain charging)
  (:requirements :typing :negative-preconditions :action-costs)
  (:types spot charge)
  (:constants refill - spot)
  (:predicates
    (robot-at ?s - spot)
    (link ?a ?b - spot)
    (stored ?c - charge ?s - spot)
    (charged)
    (full ?c - charge))
  (:functions (total-cost) - number)

  (:action move
    :parameters (?from ?to - spot)
    :precondition (and (robot-at ?from) (link ?from ?to))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) 1)))

  (:action charge
    :parameters (?c - charge ?s - spot)
    :precondition (and (robot-at ?s) (stored ?c ?s) (full ?c) (not (charged)))
    :effect (and (charged) (not (full ?c)) (increase (total-cost) 2)))

  (:action refill
    :parameters (?c - charge)
    :precondition (and (robot-at refill) (not (full ?c)) (stored ?c refill))
    :effect (and (full ?c) (increase (total-cost) 3))))
