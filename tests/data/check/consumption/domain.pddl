; A small office: a robot carries one mug between two desks and a kitchen with a sink.
; No action dirties a mug: serving coffee at a desk (a task's consumption, tasks.pddl)
; is the only thing that does, so a dirty mug is reached only through a task.
(define (domain mugs)
  (:requirements :typing :equality :negative-preconditions :action-costs)
  (:types place mug)
  (:predicates
    (robot-at ?p - place)
    (hand-free)
    (holding ?m - mug)
    (at ?m - mug ?p - place)
    (dirty ?m - mug)
    (sink ?p - place))
  (:functions (total-cost) - number (distance ?from ?to - place) - number)

  (:action move
    :parameters (?from ?to - place)
    :precondition (and (robot-at ?from) (not (= ?from ?to)))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) (distance ?from ?to))))

  (:action pick
    :parameters (?m - mug ?p - place)
    :precondition (and (hand-free) (robot-at ?p) (at ?m ?p))
    :effect (and (not (hand-free)) (holding ?m) (not (at ?m ?p)) (increase (total-cost) 1)))

  (:action place
    :parameters (?m - mug ?p - place)
    :precondition (and (holding ?m) (robot-at ?p))
    :effect (and (hand-free) (not (holding ?m)) (at ?m ?p) (increase (total-cost) 1)))

  (:action wash
    :parameters (?m - mug ?p - place)
    :precondition (and (holding ?m) (robot-at ?p) (sink ?p) (dirty ?m))
    :effect (and (not (dirty ?m)) (increase (total-cost) 2))))
