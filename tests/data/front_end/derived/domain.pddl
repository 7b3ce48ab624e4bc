; Derived predicates in two strata (front-end test): (occupied ?c) from the boxes'
; places, (free ?c) its negation, (stored) a forall over the boxes. A robot carries
; boxes on a grid; it may step, and put a box down, only onto a free cell.
(define (domain warehouse)
  (:requirements :typing :negative-preconditions :existential-preconditions
                 :universal-preconditions :derived-predicates :action-costs)
  (:types cell box)
  (:predicates
    (robot-at ?c - cell)
    (at ?b - box ?c - cell)
    (holding ?b - box)
    (hand-free)
    (next ?a ?b - cell)
    (storage ?c - cell)
    (occupied ?c - cell)
    (free ?c - cell)
    (stored))
  (:functions (total-cost) - number)

  (:derived (occupied ?c - cell) (exists (?b - box) (at ?b ?c)))
  (:derived (free ?c - cell) (not (occupied ?c)))
  (:derived (stored) (forall (?b - box) (exists (?c - cell) (and (at ?b ?c) (storage ?c)))))

  (:action move
    :parameters (?from ?to - cell)
    :precondition (and (robot-at ?from) (next ?from ?to) (free ?to))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) 1)))

  (:action pick
    :parameters (?b - box ?from ?c - cell)
    :precondition (and (hand-free) (robot-at ?from) (next ?from ?c) (at ?b ?c))
    :effect (and (not (hand-free)) (holding ?b) (not (at ?b ?c)) (increase (total-cost) 2)))

  (:action drop
    :parameters (?b - box ?from ?c - cell)
    :precondition (and (holding ?b) (robot-at ?from) (next ?from ?c) (free ?c))
    :effect (and (hand-free) (not (holding ?b)) (at ?b ?c) (increase (total-cost) 2))))
