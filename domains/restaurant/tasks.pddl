; The restaurant's task types, in PDDL: one action schema per task type.
; Its precondition is the task's goal and its effect the consumption applied
; on completion. Parameters named in tasks.toml are the task's arguments; the
; others are existential: the goal holds if some binding does, and consumption
; uses the first such binding in the problem's object order.
(define (domain restaurant-tasks)
  (:requirements :typing :negative-preconditions :existential-preconditions
                 :universal-preconditions)

  ; Some cup at ?l holds water; the first such cup is emptied (it stays clean).
  (:action serve-water
    :parameters (?l - location ?c - cup)
    :precondition (and (at ?c ?l) (has-water ?c))
    :effect (not (has-water ?c)))

  ; Some cup at ?l holds coffee; the first such cup is emptied (it stays dirty).
  (:action make-coffee
    :parameters (?l - location ?c - cup)
    :precondition (and (at ?c ?l) (has-coffee ?c))
    :effect (not (has-coffee ?c)))

  ; Some object of kind ?k is clean, empty, loose and at the wash-ready place.
  (:action wash
    :parameters (?k - kind ?w - washable ?l - location)
    :precondition (and (kind-of ?w ?k) (wash-ready ?l) (at ?w ?l) (not (dirty ?w))
                       (not (has-water ?w)) (not (has-coffee ?w))
                       (not (exists (?c - item) (in ?w ?c))))
    :effect (and))

  ; Nothing is at ?l (a held object is at no location).
  (:action clear
    :parameters (?l - location)
    :precondition (not (exists (?t - thing) (at ?t ?l)))
    :effect (and))

  ; A bowl at ?l holds an apple; the apple is taken out and left at ?l.
  (:action fruit-bowl
    :parameters (?l - location ?b - bowl ?a - apple)
    :precondition (and (at ?b ?l) (in ?a ?b))
    :effect (and (not (in ?a ?b)) (at ?a ?l) (dirty ?b)))

  ; ?o is at ?l and the hand is free.
  (:action pick-place
    :parameters (?o - washable ?l - location)
    :precondition (and (at ?o ?l) (hand-free))
    :effect (and)))
