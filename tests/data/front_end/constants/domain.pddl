; Constants (front-end test): the dock is a constant of the domain, named by an action and
; by the task schemas; parcels load only there.
(define (domain depot)
  (:requirements :typing :action-costs)
  (:types place parcel)
  (:constants dock - place)
  (:predicates
    (robot-at ?p - place)
    (road ?a ?b - place)
    (at ?x - parcel ?p - place)
    (carrying ?x - parcel))
  (:functions (total-cost) - number)

  (:action drive
    :parameters (?from ?to - place)
    :precondition (and (robot-at ?from) (road ?from ?to))
    :effect (and (not (robot-at ?from)) (robot-at ?to) (increase (total-cost) 2)))

  (:action load
    :parameters (?x - parcel)
    :precondition (and (robot-at dock) (at ?x dock))
    :effect (and (carrying ?x) (not (at ?x dock)) (increase (total-cost) 1)))

  (:action unload
    :parameters (?x - parcel ?p - place)
    :precondition (and (robot-at ?p) (carrying ?x))
    :effect (and (at ?x ?p) (not (carrying ?x)) (increase (total-cost) 1))))
