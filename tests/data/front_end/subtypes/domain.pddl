; Subtypes at every position (front-end test): a three-deep hierarchy location > desk > corner-desk
; in parameters, predicates and the arguments of the static cost function move-cost.
(define (domain office)
  (:requirements :typing :negative-preconditions :action-costs)
  (:types location item - object
          desk - location
          corner-desk - desk
          paper - item)
  (:predicates
    (robot-at ?l - location)
    (at ?i - item ?l - location)
    (holding ?i - item)
    (hand-free)
    (tray ?d - desk))
  (:functions
    (total-cost) - number
    (move-cost ?from ?to - location) - number)

  (:action move
    :parameters (?from ?to - location)
    :precondition (and (robot-at ?from) (not (= ?from ?to)))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) (move-cost ?from ?to))))

  (:action pick
    :parameters (?i - item ?l - location)
    :precondition (and (hand-free) (robot-at ?l) (at ?i ?l))
    :effect (and (not (hand-free)) (holding ?i) (not (at ?i ?l)) (increase (total-cost) 1)))

  (:action file
    :parameters (?p - paper ?d - desk)
    :precondition (and (holding ?p) (robot-at ?d) (tray ?d))
    :effect (and (hand-free) (not (holding ?p)) (at ?p ?d) (increase (total-cost) 1))))
